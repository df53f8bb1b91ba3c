% Example 1 of the paper (Sec. 6.1) with NLvib: frequency response, H = 7,
% 150 -> 250 rad/s, for one normal load n [N].
%
%   m x'' + c x' + k x + f_J(x) = F0 cos(Om t),
%   m = 1 kg, c = 0.3 N s/m, k = 3.55e4 N/m, F0 = 1 N,
%   f_J: elastic Coulomb (Jenkins) element to ground, stiffness ku = 1e4 N/m,
%   friction limit force mu n with mu = 0.5 (NLvib type 'elasticDryFriction').
%
% NLvib's HB_residual (AFT, N = 128 samples per period, two periods marched for
% the hysteresis) and its arc-length solve_and_continue set up as NLvib's own
% examples do: the harmonics scaled by the magnitude of the linear response at the
% start (qscl = |Q1|, examples 06 and 08) and the scaling adapted along the branch
% ('dynamicDscale', example 03), Om by the start frequency; step ds (default 3,
% bounds ds/5 and 5 ds), Newton (fsolve) to TolFun = TolX = tol (default 1e-9).
% Prints one line
%   RESULT n points seconds peak_amplitude peak_omega residual_evaluations final_omega cpu=CPU
% seconds (cputime: CPU): the initial solution and the continuation, measured here (Octave's
% start-up and the path set-up excluded), the median of `repeat` runs (default 1);
% amplitude: half peak-to-peak of x(t).
%
% Usage: octave --no-gui --quiet --eval "nlvib_example1('/path/to/NLvib', n)"
function nlvib_example1(nlvib_dir, n, ds, tol, repeat)
  if nargin < 3, ds = 3; end
  if nargin < 4, tol = 1e-9; end
  if nargin < 5, repeat = 1; end
  addpath(fullfile(nlvib_dir, 'SRC'));
  addpath(fullfile(nlvib_dir, 'SRC', 'MechanicalSystems'));
  m = 1; c = 0.3; k = 3.55e4; ku = 1e4; mu = 0.5; F0 = 1;
  H = 7; N = 128; Om_s = 150; Om_e = 250;

  jenkins = struct('type', 'elasticDryFriction', 'stiffness', ku, ...
                   'friction_limit_force', mu * n, 'ishysteretic', 1);
  oscillator = SingleMassOscillator(m, c, k, {jenkins}, F0);

  % initial guess: the linear response with the element stuck
  Q1 = F0 / (k + ku - Om_s^2 + 1i * Om_s * c);
  x0 = zeros(2 * H + 1, 1);
  x0(2) = real(Q1); x0(3) = -imag(Q1);

  qscale = abs(Q1);
  Sopt = struct('Dscale', [qscale * ones(size(x0)); Om_s], 'dynamicDscale', 1);
  % NLvib's default solver options (optimset(@fsolve) is MATLAB's) with the tolerance
  Solopt = optimset('Display', 'off', 'Jacobian', 'on', 'MaxIter', 50, ...
                    'TolFun', tol, 'TolX', tol);
  times = zeros(repeat, 1); cpus = zeros(repeat, 1);
  for r = 1:repeat
    t0 = tic;
    c0 = cputime;
    [X, Solinfo] = solve_and_continue(x0, ...
        @(X) HB_residual(X, oscillator, H, N, 'frf'), Om_s, Om_e, ds, Sopt, [], Solopt);
    times(r) = toc(t0);
    cpus(r) = cputime - c0;
  end
  seconds = median(times);
  cpu = median(cpus);

  % half peak-to-peak amplitude of x(t) at every point, 512 samples per period
  tau = 2 * pi * (0:511)' / 512;
  E = [ones(size(tau)), zeros(numel(tau), 2 * H)];
  E(:, 2:2:end) = cos(tau * (1:H));
  E(:, 3:2:end) = sin(tau * (1:H));
  x = E * X(1:end-1, :);
  a = (max(x, [], 1) - min(x, [], 1)) / 2;
  [apk, ipk] = max(a);
  printf('RESULT %g %d %.6f %.10g %.10g %d %.4f cpu=%.6f\n', n, size(X, 2), seconds, apk, ...
         X(end, ipk), Solinfo.FCtotal, X(end, end), cpu);
end
