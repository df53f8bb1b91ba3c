"""An added linear term of the dynamic stiffness (`dynamic_stiffness`): a mass-
proportional damping, a gyroscopic matrix, the negative damping of the extended
periodic motion concept -- each enters S_h as a_t(w) A_t, its coefficient a_t given
here, the sum formed in `dynamic_stiffness` only."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, eq=False)
class Term:
    """An added linear term a A of the dynamic stiffness, a = w^power Omega^omega_power
    (times i if imag), w = h Omega: Omega^q A d^p q/dt^p is Term(A (-1)^(p//2), p, p odd,
    q)."""

    matrix: object        # (n, n), dense or scipy.sparse, as the system's matrices
    power: int            # power of w = h Omega (>= 1)
    imag: bool = False    # multiplied by i
    omega_power: int = 0  # power of Omega itself (a matrix proportional to Omega^q)

    def __post_init__(self):
        if int(self.power) < 1:
            raise ValueError(f"a term's power of h Omega must be >= 1, got {self.power}")

    def factor(self, w, Om):
        """a at w = h Omega."""
        a = w ** self.power
        if self.omega_power:
            a = a * Om ** self.omega_power
        return 1j * a if self.imag else a

    def rate(self, h, w, Om):
        """da/dOmega = h p w^(p-1) Omega^q + q w^p Omega^(q-1) (times i)."""
        p, q = self.power, self.omega_power
        a = h * p * w ** (p - 1)
        if q:
            a = a * Om ** q + q * w ** p * Om ** (q - 1)
        return 1j * a if self.imag else a
