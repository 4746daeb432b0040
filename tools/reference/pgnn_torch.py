#!/usr/bin/python3
"""PyTorch reference implementation of the PGNN identification (Algorithm 2).

The same model, data, split, normalisation, physics-only target and cost as
our identification of the paper's PGNN (`clm identify --no-nuisance
--no-selection`; docs/commutation.md, docs/commissioning.md), trained with a different
optimiser (full-batch L-BFGS with strong-Wolfe line search instead of
Levenberg-Marquardt on decimated data), so that our C++ identification can be
benchmarked against a mainstream implementation (docs/benchmarks.md,
"Identification against PyTorch").

Per coil set l (eq. 23-26 of the paper, docs/commutation.md §7 and §8):

    F̂ = K̂(y)·[i_a, i_b] + F̂_cog(y)
    K̂(y) = A cos(2πy/d_m) + B sin(2πy/d_m) + [f_a(y_n), f_b(y_n)]
    f_a, f_b: 1 -> tanh(2) -> 3,  f_cog: 1 -> tanh(16) -> 3,
    y_n = (y - offset)/scale in [-1, 1] over all positions of all coil sets
    V = mean_t ||F(t) - F̂(t)||² + λ² ||θ_phy - θ*_phy||²      (26), λ = 0.1

with θ*_phy the physics-only least-squares fit (A, B and a constant force
beside them, without networks; docs/commutation.md, "Nuisance terms", item 3)
on the training data, and eq. (31) (ridge least squares of A, B and the output
layers with the hidden layers fixed) applied at the end, as ours does, which
guarantees Proposition 4.1 (the model's training data term never exceeds the
physics-only one, direction by direction; checked and reported).

Identical to ours:
  * data: the experiment CSV (docs/data-formats.md), rows grouped per coil set
    by delta_rad in file order; the wrench of a row paired with the setpoint
    of its previous cycle at the row's own position, the first row of each run
    left out (docs/commissioning.md, "Experiment data"); currents of that
    setpoint through the drive's fixed commutation (eq. 19):
    i = [sin(η), sin(η + 2π/3)]·m/k̂_d, η = 2πy/d_m + ζ̂_d + Δ; the previous
    cycle's ia_A/ib_A instead when the CSV has them;
  * split: split_contiguous_blocks (dataset.cpp), validation fraction 0.2,
    10 contiguous blocks per offset group, blocks 2 and 7 held out;
  * normalisation: normalisation_for over all positions of all coil sets;
  * initial points: the same seeded draws as ours (std::mt19937_64 with seed
    1 + 1000·l, slopes U(-4, 4), centres U(-1, 1), bias = -slope·centre, in
    the same order), reproduced bit for bit below; output layers and A, B then
    by eq. (31), as the paper initialises them (on all training samples; ours
    on the every-16th-sample set its restarts use);
  * restarts: the same number (5), then the best continued (here the lowest
    cost (26); ours keeps the one that predicts the held-out blocks best and
    polishes it once more on every sample, docs/commutation.md
    "Identification");
  * float64 throughout.

Different (by design, this is the reference):
  * optimiser: torch.optim.LBFGS, full batch (every training sample in every
    iteration; ours decimates), lr 1, strong-Wolfe line search, history 100
    (torch's default; 20 converges far slower here), budget
    --restart-iterations per restart and --final-iterations for the
    continuation of the best (defaults 200 and 5000; max_eval 1.25× each),
    tolerance_grad 1e-10, tolerance_change 1e-13 (so the budget, not a
    tolerance, ends the run);
  * --optimiser scipy: the same budget and history with SciPy's L-BFGS-B
    (the Fortran code of Byrd, Lu, Nocedal and Zhu, its own Moré–Thuente
    line search on the strong Wolfe conditions, no bounds), the cost and its
    gradient still from torch: a second, independent implementation of the
    same training (python3-scipy);
  * torch.set_num_threads(--threads) (default 2, like ours), with
    OMP_WAIT_POLICY=PASSIVE unless set otherwise: on a loaded machine OpenMP's
    busy waiting made two threads ~8x slower than one.

With --target-costs (ours' final costs) the report gives, per coil set, the
wall and CPU time at which L-BFGS first reached that cost (any evaluation of
any restart, before eq. 31), and a convergence trace (best cost every 100
evaluations).

Wall time per coil set covers everything after the CSV is parsed: physics
fit, restarts, continuation, eq. (31) and the data-term evaluation; the total
adds the split, normalisation and writing the model (not the Python/torch
import and CSV parsing; printed separately).

Output: the model in our YAML format (docs/model-format.md), loadable by
`clm`, the daemon and tests/bench/compare_models, and a JSON report.
"""

import argparse
import datetime
import hashlib
import json
import math
import os
import sys
import time

import numpy as np

TWO_PI = 2.0 * math.pi
TWO_PI_OVER_THREE = 2.0 * math.pi / 3.0


# --------------------------------------------------------------------------
# std::mt19937_64 and libstdc++'s std::uniform_real_distribution<double>,
# so that the restarts start from exactly the points ours starts from.
class Mt19937_64:
    _N, _M = 312, 156
    _MATRIX_A = 0xB5026F5AA96619E9
    _UPPER, _LOWER = 0xFFFFFFFF80000000, 0x7FFFFFFF
    _MASK = (1 << 64) - 1

    def __init__(self, seed):
        mt = [0] * self._N
        mt[0] = seed & self._MASK
        for i in range(1, self._N):
            mt[i] = (6364136223846793005 * (mt[i - 1] ^ (mt[i - 1] >> 62)) + i) & self._MASK
        self._mt = mt
        self._index = self._N

    def _twist(self):
        mt, n, m = self._mt, self._N, self._M
        for i in range(n):
            x = (mt[i] & self._UPPER) | (mt[(i + 1) % n] & self._LOWER)
            xa = x >> 1
            if x & 1:
                xa ^= self._MATRIX_A
            mt[i] = mt[(i + m) % n] ^ xa
        self._index = 0

    def __call__(self):
        if self._index >= self._N:
            self._twist()
        x = self._mt[self._index]
        self._index += 1
        x ^= (x >> 29) & 0x5555555555555555
        x ^= (x << 17) & 0x71D67FFFEDA60000
        x ^= (x << 37) & 0xFFF7EEE000000000
        x ^= x >> 43
        return x & self._MASK

    def uniform(self, low, high):
        # generate_canonical<double, 53> with a 64-bit engine: one draw / 2^64.
        r = float(self()) / 18446744073709551616.0
        if r >= 1.0:
            r = math.nextafter(1.0, 0.0)
        return r * (high - low) + low


def self_test_rng():
    rng = Mt19937_64(5489)  # std::mt19937_64's default seed
    for _ in range(9999):
        rng()
    assert rng() == 9981545732273789042, "mt19937_64 replica is wrong"


# --------------------------------------------------------------------------
# Inputs.
def load_motor(path):
    import yaml  # Debian python3-yaml

    with open(path) as f:
        root = yaml.safe_load(f)
    if "motor" not in root and "motor_file" in root:  # a daemon configuration
        return load_motor(os.path.join(os.path.dirname(path), root["motor_file"]))
    return {
        "pole_pitch_m": float(root["motor"]["pole_pitch_m"]),
        "coil_sets": int(root["motor"]["coil_sets"]),
        "k_d": float(root["drive"]["commutation"]["motor_constant_N_per_A"]),
        "zeta_d": float(root["drive"]["commutation"]["phase_offset_rad"]),
    }


def load_experiments(path, motor):
    """Per coil set: position, currents (2×N), wrench (N×3), group (0/1), from
    the experiment CSV as docs/data-formats.md and docs/commissioning.md
    ("Experiment data") define it.

    A row holds the position and wrench its cycle measured and the setpoint
    its cycle computed; the drive applies that setpoint over the period after
    the row. So the wrench of row k pairs with the setpoint of row k − 1 (its
    previous cycle: the row before it in the file, same coil set and offset
    group, a time step above 0 and at most 1.5 median steps) at row k's
    position. The first row of each run has no previous cycle and is left out.
    """
    with open(path) as f:
        header = f.readline().strip().split(",")
    table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    col = {name: table[:, header.index(name)] for name in header}
    measured = "ia_A" in col or "ib_A" in col
    d_m, k_d, zeta_d = motor["pole_pitch_m"], motor["k_d"], motor["zeta_d"]
    coil_set, delta, time_s = col["coil_set"], col["delta_rad"], col["t_s"]

    # Offset group of every row, per coil set: the offsets in order of
    # appearance, a row in the group of the last offset within 1e-9 rad.
    group = np.full(coil_set.size, -1)
    for l in range(1, motor["coil_sets"] + 1):
        rows = np.nonzero(coil_set == l)[0]
        if rows.size == 0:
            raise SystemExit(f"{path}: no rows for coil set {l}")
        d = delta[rows]
        near_first = np.abs(d - d[0]) <= 1e-9
        if near_first.all():
            raise SystemExit(f"{path}: coil set {l} has a single phase offset")
        second_at = int(np.argmin(near_first))
        near_second = np.abs(d - d[second_at]) <= 1e-9
        near_second[:second_at] = False  # the second offset did not exist yet
        if not np.all(near_first | near_second):
            raise SystemExit(f"{path}: coil set {l} has a third phase offset")
        group[rows] = np.where(near_second, 1, 0)

    # The time step of a run: the median of the file's positive steps (of an
    # even count, the upper of the two middle ones).
    step = np.diff(time_s)
    positive = np.sort(step[step > 0.0])
    median_step_s = positive[positive.size // 2] if positive.size else 0.0
    paired = np.zeros(coil_set.size, dtype=bool)
    paired[1:] = ((coil_set[1:] == coil_set[:-1]) & (group[1:] == group[:-1]) & (step > 0.0)
                  & (step <= 1.5 * median_step_s))

    sets = []
    for l in range(1, motor["coil_sets"] + 1):
        rows = np.nonzero((coil_set == l) & paired)[0]  # row k: its force, position and group
        before = rows - 1                                 # row k − 1: the setpoint that made the force
        for g in (0, 1):
            if not np.any(group[rows] == g):
                raise SystemExit(f"{path}: coil set {l}, offset group {g + 1}: no two consecutive cycles")
        y = col["y_m"][rows]
        if measured:
            currents = np.vstack([col["ia_A"][before], col["ib_A"][before]])
        else:
            # The drive's fixed commutation (eq. 19) of row k − 1's setpoint at
            # row k's position: sin(2πy/d_m + ζ̂_d + Δ)·m/k̂_d for coil a, +2π/3 for b.
            angle = (TWO_PI * y / d_m + zeta_d) + delta[before]
            scale = col["magnitude_N"][before] / k_d
            currents = np.vstack([scale * np.sin(angle), scale * np.sin(angle + TWO_PI_OVER_THREE)])
        wrench = np.column_stack([col["Fy_N"][rows], col["Fx_N"][rows], col["Tz_Nm"][rows]])
        sets.append({"y": y, "i": currents, "F": wrench, "group": group[rows]})
    return sets, measured


def split_contiguous_blocks(group, validation_fraction=0.2, blocks_per_group=10):
    """dataset.cpp split_contiguous_blocks, reproduced step by step."""
    held_out = int(math.floor(validation_fraction * blocks_per_group + 0.5))  # std::lround, x ≥ 0
    is_validation = [False] * blocks_per_group
    for k in range(held_out):
        block = int((k + 0.5) * blocks_per_group / held_out)
        is_validation[min(block, blocks_per_group - 1)] = True
    training, validation = [], []
    for g in (0, 1):
        members = np.nonzero(group == g)[0]
        count = float(members.size)
        for k, index in enumerate(members):
            block = int(min(blocks_per_group - 1, math.floor(k * blocks_per_group / count)))
            (validation if is_validation[block] else training).append(index)
    return np.array(training, dtype=np.int64), np.array(validation, dtype=np.int64)


def subset(data, indices):
    return {"y": data["y"][indices], "i": data["i"][:, indices], "F": data["F"][indices],
            "group": data["group"][indices]}


def normalisation_for(positions):
    low, high = positions.min(), positions.max()
    half = 0.5 * (high - low)
    return 0.5 * (high + low), (half if half > 0.0 else 1.0)


# --------------------------------------------------------------------------
# The model. Regressor M (N × p) of eq. (28), the same for all directions:
#   [c·ia, c·ib, s·ia, s·ib | h_a·ia (na), h_b·ib (na), h_cog (nc) | ia, ib, 1]
# and Θ (p × 3), column q the linear parameters θ_L,q of eq. (29).
class Structure:
    def __init__(self, na, nc):
        self.na, self.nc = na, nc
        self.hidden = 2 * na + nc
        self.p = 4 + self.hidden + 3


def physics_regressor(y, i, d_m):
    theta = TWO_PI * y / d_m
    c, s = np.cos(theta), np.sin(theta)
    return np.column_stack([c * i[0], c * i[1], s * i[0], s * i[1]])


def fit_physics_only(data, d_m):
    """The physics-only fit (docs/commutation.md §8 and "Nuisance terms", item 3):
    A, B and a constant force beside them, by least squares per direction.
    Returns θ*_phy (4 × 3, column q = [A_q0, A_q1, B_q0, B_q1]), the target of
    the prior in eq. (26), and the constant (3,), which the prior does not see."""
    m = np.column_stack([physics_regressor(data["y"], data["i"], d_m), np.ones(data["y"].size)])
    solution, *_ = np.linalg.lstsq(m, data["F"], rcond=None)
    return solution[:4], solution[4]


class Problem:
    """One coil set's training data as float64 tensors, and the cost (26)."""

    def __init__(self, torch, data, d_m, normalisation, structure, theta_star, regularisation):
        self.torch = torch
        t = lambda a: torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float64)
        self.s = structure
        self.n = data["y"].size
        self.x = t((data["y"] - normalisation[0]) / normalisation[1]).unsqueeze(1)
        ia, ib = data["i"][0], data["i"][1]
        self.m_phys = t(physics_regressor(data["y"], data["i"], d_m))
        multiplier = np.column_stack([np.repeat(ia[:, None], structure.na, 1), np.repeat(ib[:, None], structure.na, 1),
                                      np.ones((self.n, structure.nc))])
        self.multiplier = t(multiplier)
        self.m_tail = t(np.column_stack([ia, ib, np.ones(self.n)]))
        self.F = t(data["F"])
        self.theta_star = t(theta_star)
        self.lambda2 = regularisation * regularisation

    def regressor(self, w, b):
        hidden = self.torch.tanh(self.x * w + b) * self.multiplier
        return self.torch.cat([self.m_phys, hidden, self.m_tail], dim=1)

    def cost(self, w, b, theta):
        # = F − regressor(w, b) @ theta without materialising the regressor.
        s = self.s
        hidden = self.torch.tanh(self.torch.addcmul(b, self.x, w)) * self.multiplier
        residual = (self.F - self.m_phys @ theta[:4] - hidden @ theta[4:4 + s.hidden]
                    - self.m_tail @ theta[4 + s.hidden:])
        data_term = residual.square().sum() / self.n
        prior = self.lambda2 * ((theta[:4] - self.theta_star) ** 2).sum()
        return data_term + prior

    def ridge(self, w, b):
        """Eq. (31) with the hidden layers (w, b) fixed: same normal equations as ridge_linear."""
        torch = self.torch
        with torch.no_grad():
            m = self.regressor(w, b)
            gram = m.T @ m / self.n
            rhs = m.T @ self.F / self.n
            diag = torch.zeros(self.s.p, dtype=torch.float64)
            diag[:4] = self.lambda2
            diag[4:] = 1e-10 * (1.0 + torch.diagonal(gram)[4:])  # ours: tiny ridge on the output layers
            gram = gram + torch.diag(diag)
            rhs = rhs.clone()
            rhs[:4] += self.lambda2 * self.theta_star
            return torch.linalg.solve(gram, rhs)


def initial_hidden(rng, structure):
    """Hidden weights and biases in our draw order: column a, column b, cogging."""
    w, b = [], []
    for width in (structure.na, structure.na, structure.nc):
        for _ in range(width):
            slope = rng.uniform(-4.0, 4.0)
            w.append(slope)
            b.append(-slope * rng.uniform(-1.0, 1.0))
    return np.array(w), np.array(b)


class Watch:
    """Wall and CPU time since the coil set started at which cost (26) first
    reached `target` (ours' final cost), over every evaluation of every restart."""

    def __init__(self, target):
        self.target = target
        self.start_wall = time.perf_counter()
        self.start_cpu = time.process_time()
        self.best = math.inf
        self.reached = None
        self.evaluations = 0
        self.convergence = []  # [evaluations, wall s, CPU s, best cost so far] every 100 evaluations

    def see(self, cost):
        self.best = min(self.best, cost)
        self.evaluations += 1
        if self.evaluations % 100 == 0:
            self.convergence.append([self.evaluations, time.perf_counter() - self.start_wall,
                                     time.process_time() - self.start_cpu, self.best])
        if self.reached is None and self.target is not None and cost <= self.target:
            self.reached = {"wall_s": time.perf_counter() - self.start_wall,
                            "cpu_s": time.process_time() - self.start_cpu}


def lbfgs(torch, problem, w, b, theta, iterations, history, watch):
    params = [p.detach().contiguous().clone().requires_grad_(True) for p in (w, b, theta)]
    optimiser = torch.optim.LBFGS(params, lr=1.0, max_iter=iterations, max_eval=int(iterations * 1.25) + 1,
                                  tolerance_grad=1e-10, tolerance_change=1e-13, history_size=history,
                                  line_search_fn="strong_wolfe")

    def closure():
        optimiser.zero_grad()
        loss = problem.cost(*params)
        loss.backward()
        watch.see(float(loss))
        return loss

    optimiser.step(closure)
    state = optimiser.state[optimiser._params[0]]
    with torch.no_grad():
        final = float(problem.cost(*params))
    return [p.detach() for p in params], final, int(state.get("n_iter", 0)), int(state.get("func_evals", 0))


def lbfgs_scipy(torch, problem, w, b, theta, iterations, history, watch):
    """lbfgs() by SciPy's L-BFGS-B: the same budget, history and tolerances."""
    from scipy.optimize import minimize
    shapes = [tuple(p.shape) for p in (w, b, theta)]
    sizes = [p.numel() for p in (w, b, theta)]

    def unpack(x):
        parts = torch.split(torch.from_numpy(np.array(x, dtype=np.float64)), sizes)
        return [part.reshape(shape).clone().requires_grad_(True) for part, shape in zip(parts, shapes)]

    def cost_and_gradient(x):
        params = unpack(x)
        loss = problem.cost(*params)
        loss.backward()
        watch.see(float(loss))
        return float(loss), torch.cat([p.grad.reshape(-1) for p in params]).numpy()

    x0 = torch.cat([p.detach().reshape(-1) for p in (w, b, theta)]).numpy()
    # ftol is relative to max(|f|, 1); the cost (26) is of order 1, so
    # 1e-13 matches torch's tolerance_change: the budget ends the run.
    result = minimize(cost_and_gradient, x0, jac=True, method="L-BFGS-B",
                      options={"maxiter": iterations, "maxfun": int(iterations * 1.25) + 1, "maxcor": history,
                               "ftol": 1e-13, "gtol": 1e-10, "maxls": 25})
    params = [p.detach() for p in unpack(result.x)]
    with torch.no_grad():
        final = float(problem.cost(*params))
    return params, final, int(result.nit), int(result.nfev)


def data_terms(torch, structure, d_m, normalisation, data, w, b, theta):
    """Mean squared error per direction [y, x, z] (coil_set_cost)."""
    if data["y"].size == 0:
        return [0.0, 0.0, 0.0]
    problem = Problem(torch, data, d_m, normalisation, structure, np.zeros((4, 3)), 0.0)
    with torch.no_grad():
        residual = problem.F - problem.regressor(w, b) @ theta
        return [float(v) for v in (residual * residual).mean(dim=0)]


def identify_coil_set(torch, training, validation, d_m, normalisation, structure, args, seed, target=None):
    watch = Watch(target)
    theta_star, physics_constant = fit_physics_only(training, d_m)
    problem = Problem(torch, training, d_m, normalisation, structure, theta_star, args.regularisation)
    rng = Mt19937_64(seed)
    best = None
    trace = []
    iterations = evaluations = 0
    train = lbfgs_scipy if args.optimiser == "scipy" else lbfgs
    for restart in range(args.restarts):
        w0, b0 = initial_hidden(rng, structure)
        w = torch.as_tensor(w0, dtype=torch.float64)
        b = torch.as_tensor(b0, dtype=torch.float64)
        theta = problem.ridge(w, b)  # linear parameters initialised by eq. (31), as the paper does
        (w, b, theta), cost, n_iter, n_eval = train(torch, problem, w, b, theta, args.restart_iterations, args.history,
                                                    watch)
        iterations += n_iter
        evaluations += n_eval
        trace.append({"restart": restart, "cost": cost, "iterations": n_iter, "evaluations": n_eval})
        if best is None or cost < best[0]:
            best = (cost, restart, w, b, theta)
    _, best_restart, w, b, theta = best
    final_cost = best[0]
    if args.final_iterations > 0:
        (w, b, theta), final_cost, n_iter, n_eval = train(torch, problem, w, b, theta, args.final_iterations,
                                                          args.history, watch)
        iterations += n_iter
        evaluations += n_eval
    trace.append({"restart": "continuation", "cost": final_cost})
    # Eq. (31) last, on all training samples: Proposition 4.1 then holds.
    theta = problem.ridge(w, b)
    with torch.no_grad():
        regularised = float(problem.cost(w, b, theta))
    watch.see(regularised)
    zero_hidden = torch.zeros(structure.hidden, dtype=torch.float64)
    physics_theta = torch.zeros((structure.p, 3), dtype=torch.float64)
    physics_theta[:4] = torch.as_tensor(theta_star)
    physics_theta[-1] = torch.as_tensor(physics_constant)  # the regressor's last column is 1
    terms = lambda data, w_, b_, theta_: data_terms(torch, structure, d_m, normalisation, data, w_, b_, theta_)
    result = {
        "physics_training_N2": terms(training, zero_hidden, zero_hidden, physics_theta),
        "model_training_N2": terms(training, w, b, theta),
        "physics_validation_N2": terms(validation, zero_hidden, zero_hidden, physics_theta),
        "model_validation_N2": terms(validation, w, b, theta),
    }
    result.update({
        "wall_time_s": time.perf_counter() - watch.start_wall,
        "cpu_time_s": time.process_time() - watch.start_cpu,
        "target_cost": target,
        "target_reached": watch.reached,
        "convergence": watch.convergence,
        "regularised_cost": regularised,
        "cost_before_eq31": final_cost,
        "best_restart": best_restart,
        "iterations": iterations,
        "function_evaluations": evaluations,
        "training_samples": int(training["y"].size),
        "validation_samples": int(validation["y"].size),
        "trace": trace,
        "proposition_4_1_holds": all(m <= p * (1 + 1e-9) + 1e-12 for m, p in
                                      zip(result["model_training_N2"], result["physics_training_N2"])),
    })
    return result, (w.numpy(), b.numpy(), theta.numpy())


# --------------------------------------------------------------------------
# Our model file (docs/model-format.md).
def g17(value):
    return "%.17g" % value


def flow(values):
    return "[" + ", ".join(g17(v) for v in values) + "]"


def matrix(rows):
    return "[" + ", ".join(flow(r) for r in rows) + "]"


def network_yaml(indent, hidden_w, hidden_b, out_w, out_b):
    pad = " " * indent
    return (f"{pad}hidden_sizes: [{len(hidden_w)}]\n"
            f"{pad}activation: tanh\n"
            f"{pad}layers:\n"
            f"{pad}  - weights: {matrix([[v] for v in hidden_w])}\n"
            f"{pad}    biases: {flow(hidden_b)}\n"
            f"{pad}  - weights: {matrix(out_w)}\n"
            f"{pad}    biases: {flow(out_b)}\n")


def model_yaml(motor, normalisation, structure, parameters, results, data_sha256, generator):
    na, nc = structure.na, structure.nc
    lines = ["# clm-servo model (PGNN, eq. 22-25) from the PyTorch reference tools/reference/pgnn_torch.py;",
             "# format in docs/model-format.md",
             "format: clm-servo-model", "format_version: 1", "kind: pgnn", "motor:",
             f"  pole_pitch_m: {g17(motor['pole_pitch_m'])}", f"  coil_sets: {motor['coil_sets']}",
             "position_normalisation:", f"  offset_m: {g17(normalisation[0])}", f"  scale_m: {g17(normalisation[1])}",
             "coil_sets:"]
    text = "\n".join(lines) + "\n"
    for w, b, theta in parameters:
        a = [[theta[0, q], theta[1, q]] for q in range(3)]
        bb = [[theta[2, q], theta[3, q]] for q in range(3)]
        text += f"  - A_N_per_A: {matrix(a)}\n    B_N_per_A: {matrix(bb)}\n"
        bias_row = 4 + structure.hidden
        parts = (("column_a", 0, na, bias_row), ("column_b", na, na, bias_row + 1),
                 ("cogging", 2 * na, nc, bias_row + 2))
        for name, first, width, bias in parts:
            out_w = [[theta[4 + first + j, q] for j in range(width)] for q in range(3)]
            out_b = [theta[bias, q] for q in range(3)]
            text += f"    {name}:\n" + network_yaml(6, w[first:first + width], b[first:first + width], out_w, out_b)
    created = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    text += (f"provenance:\n  data_sha256: \"{data_sha256}\"\n  created_utc: \"{created}\"\n"
             f"  generator: \"{generator}\"\n  costs:\n")
    for r in results:
        text += (f"    - physics_training_N2: {flow(r['physics_training_N2'])}\n"
                 f"      model_training_N2: {flow(r['model_training_N2'])}\n"
                 f"      physics_validation_N2: {flow(r['physics_validation_N2'])}\n"
                 f"      model_validation_N2: {flow(r['model_validation_N2'])}\n")
    return text


def write_atomically(path, text):
    temporary = path + ".tmp"
    with open(temporary, "w") as f:
        f.write(text)
    os.replace(temporary, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="experiment CSV (docs/data-formats.md)")
    parser.add_argument("--motor", required=True, help="motor description or daemon configuration (YAML)")
    parser.add_argument("--out", required=True, help="model file to write (our YAML format)")
    parser.add_argument("--report", help="JSON report to write")
    parser.add_argument("--validation-fraction", type=float, default=0.2)
    parser.add_argument("--column-neurons", type=int, default=2)
    parser.add_argument("--cogging-neurons", type=int, default=16)
    parser.add_argument("--regularisation", type=float, default=0.1)
    parser.add_argument("--restarts", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1, help="as clm --seed; coil set l uses seed + 1000·l")
    parser.add_argument("--restart-iterations", type=int, default=200, help="L-BFGS iterations per restart")
    parser.add_argument("--final-iterations", type=int, default=5000, help="L-BFGS iterations continuing the best")
    parser.add_argument("--history", type=int, default=100, help="L-BFGS history size (torch's default)")
    parser.add_argument("--threads", type=int, default=2, help="torch.set_num_threads")
    parser.add_argument("--optimiser", choices=("torch", "scipy"), default="torch",
                        help="L-BFGS of torch.optim (default) or SciPy's L-BFGS-B, an independent implementation")
    parser.add_argument("--coil-set", type=int, default=0,
                        help="train this coil set only (1-based; for convergence studies: no model is written)")
    parser.add_argument("--target-costs", help="comma-separated cost (26) per coil set (ours); the report gives the "
                                               "time at which L-BFGS first reached each")
    args = parser.parse_args()

    # On a shared, loaded machine OpenMP's default busy-waiting makes two
    # threads ~8x slower than one; passive waiting removes that. Override by
    # setting OMP_WAIT_POLICY in the environment.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    t0 = time.perf_counter()
    import torch
    torch.set_num_threads(args.threads)
    import_s = time.perf_counter() - t0
    self_test_rng()

    t0 = time.perf_counter()
    motor = load_motor(args.motor)
    sets, measured = load_experiments(args.data, motor)
    with open(args.data, "rb") as f:
        data_sha256 = hashlib.sha256(f.read()).hexdigest()
    read_s = time.perf_counter() - t0

    targets = [float(v) for v in args.target_costs.split(",")] if args.target_costs else [None] * len(sets)
    if len(targets) != len(sets):
        raise SystemExit(f"--target-costs: {len(targets)} values for {len(sets)} coil sets")
    start = time.perf_counter()
    start_cpu = time.process_time()
    structure = Structure(args.column_neurons, args.cogging_neurons)
    normalisation = normalisation_for(np.concatenate([s["y"] for s in sets]))
    results, parameters = [], []
    for l, data in enumerate(sets, start=1):
        if args.coil_set and l != args.coil_set:
            continue
        training_idx, validation_idx = split_contiguous_blocks(data["group"], args.validation_fraction)
        training, validation = subset(data, training_idx), subset(data, validation_idx)
        result, params = identify_coil_set(torch, training, validation, motor["pole_pitch_m"], normalisation,
                                           structure, args, args.seed + 1000 * l, targets[l - 1])
        result["coil_set"] = l
        results.append(result)
        parameters.append(params)
        print(f"coil set {l}: cost (26) {result['regularised_cost']:.6g} "
              f"(before eq. 31: {result['cost_before_eq31']:.6g}), "
              f"{result['iterations']} L-BFGS iterations / {result['function_evaluations']} evaluations, "
              f"best restart {result['best_restart'] + 1}, {result['wall_time_s']:.2f} s wall, "
              f"{result['cpu_time_s']:.2f} s CPU, "
              f"Prop. 4.1 {'holds' if result['proposition_4_1_holds'] else 'VIOLATED'}",
              flush=True)
        triple = lambda key: " ".join(f"{v:.4g}" for v in result[key])
        print(f"  data terms y x z [N², N², N²m²]: training {triple('model_training_N2')} "
              f"(physics-only {triple('physics_training_N2')}), validation {triple('model_validation_N2')} "
              f"(physics-only {triple('physics_validation_N2')})", flush=True)
        if result["target_cost"] is not None:
            reached = result["target_reached"]
            print(f"  target cost {result['target_cost']:.6g}: " +
                  (f"reached after {reached['wall_s']:.2f} s wall, {reached['cpu_s']:.2f} s CPU" if reached
                   else "not reached within the budget"), flush=True)
    generator = (f"tools/reference/pgnn_torch.py (PyTorch {torch.__version__}, " +
                 ("SciPy L-BFGS-B)" if args.optimiser == "scipy" else "L-BFGS)"))
    if not args.coil_set:
        text = model_yaml(motor, normalisation, structure, parameters, results, data_sha256, generator)
        write_atomically(args.out, text)
    total_s = time.perf_counter() - start
    total_cpu_s = time.process_time() - start_cpu

    report = {
        "generator": generator,
        "torch_version": torch.__version__,
        "threads": args.threads,
        "measured_currents": measured,
        "options": {k: v for k, v in vars(args).items() if k not in ("data", "motor", "out", "report")},
        "normalisation": {"offset_m": normalisation[0], "scale_m": normalisation[1]},
        "import_s": import_s,
        "read_s": read_s,
        "identify_wall_time_s": total_s,
        "identify_cpu_time_s": total_cpu_s,
        "coil_sets": results,
    }
    if args.report:
        write_atomically(args.report, json.dumps(report, indent=2) + "\n")
    written = f"wrote {args.out}" if not args.coil_set else "no model written (--coil-set)"
    print(f"identification {total_s:.2f} s wall, {total_cpu_s:.2f} s CPU (torch import {import_s:.2f} s and "
          f"CSV reading {read_s:.2f} s not included); {written}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
