"""Shared numerical kernels of the planners: sparse policy evaluation, φ matrices, sampling."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any, NamedTuple

import numba
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from conjure.core.interfaces import DomainSpec, Representation
from conjure.core.linalg import feature_matrix, row_matrix
from conjure.models.generative import GenerativeModel
from conjure.models.steady_state import steady_state_distribution
from conjure.models.tabular_model import TabularModel
from conjure.planners.base import Iterations, Plan

#: Above this many states policy evaluation is iterative (BiCGSTAB) rather than a sparse LU.
DIRECT_SOLVE_LIMIT = 200_000


def evaluate_policy(
    model: TabularModel,
    policy: np.ndarray,
    *,
    method: str = "auto",
    initial: np.ndarray | None = None,
    max_sweeps: int = 10_000,
    tolerance: float = 1e-10,
) -> np.ndarray:
    """V^π = (I − γP^π)⁻¹R^π over the non-terminal states (Eq. 2.8), sparse; V(terminal) = 0.

    ``method`` is ``direct`` (sparse LU), ``iterative`` (BiCGSTAB) or ``auto`` (direct up to
    `DIRECT_SOLVE_LIMIT` states). If the system is singular (an improper policy with γ = 1),
    the value is estimated by ``max_sweeps`` Bellman sweeps of the fixed policy instead.
    """
    n = model.num_states
    live = np.flatnonzero(~model.is_terminal)
    p_pi = model.policy_matrix(policy)[live][:, live]
    r_pi = model.policy_rewards(policy)[live]
    system = sp.identity(live.size, format="csc") - model.discount * sp.csc_matrix(p_pi)
    values = np.zeros(n)
    if method == "auto":
        method = "direct" if n <= DIRECT_SOLVE_LIMIT else "iterative"
    solution = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if method == "direct":
            try:
                solution = spla.splu(system).solve(r_pi)
            except RuntimeError:  # exactly singular
                solution = None
        else:
            x0 = None if initial is None else initial[live]
            solution, info = spla.bicgstab(system, r_pi, x0=x0, rtol=1e-10, maxiter=5000)
            if info != 0:
                solution = None
    if solution is None or not np.all(np.isfinite(solution)):
        current = np.zeros(live.size) if initial is None else initial[live].copy()
        p_csr = sp.csr_matrix(p_pi)
        for _ in range(max_sweeps):
            following = r_pi + model.discount * (p_csr @ current)
            if np.abs(following - current).max(initial=0.0) < tolerance:
                current = following
                break
            current = following
        solution = current
    values[live] = solution
    return values


def initial_policy(model: TabularModel, rng: np.random.Generator) -> np.ndarray:
    """π₀ ← Random() (line 1 of Algorithms 1, 3, 4, 6), with π(terminal) = 0 (`TabularModel`)."""
    policy = rng.integers(model.num_actions, size=model.num_states)
    policy[model.is_terminal] = 0
    return policy


def greedy_policy(q: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """Argmax over actions of Q given as q[s, a]; ties keep the previous action (no cycling)."""
    best = q.argmax(axis=1)
    if previous is not None:
        states = np.arange(q.shape[0])
        top = q[states, best]
        keep = q[states, previous] >= top - 1e-12 * np.maximum(1.0, np.abs(top))
        best = np.where(keep, previous, best)
    return best.astype(np.int64)


def improve_policy(q: np.ndarray, policy: np.ndarray) -> tuple[np.ndarray, int]:
    """π⁺(s) = argmax_a q[s, a] (Eq. 2.9, ties keep π) and how many states changed action."""
    improved = greedy_policy(q, policy)
    return improved, int(np.count_nonzero(improved != policy))


def action_features(phi: sp.csr_matrix, actions: np.ndarray, num_actions: int) -> sp.csr_matrix:
    """Return Φ̄ rows φ(s_i, a_i): φ(s_i) moved to action a_i's slot (Eq. 2.11, column a·n + f)."""
    n = phi.shape[1]
    phi = sp.csr_matrix(phi)
    return row_matrix(
        phi.indices, phi.indptr, n * num_actions, phi.data, np.asarray(actions, dtype=np.int64) * n
    )


def weights_by_action(theta: np.ndarray, num_actions: int) -> np.ndarray:
    """θ̄ of length n|A| (Eq. 2.11's column a·n + f) as an (n, |A|) view, one column per action."""
    return theta.reshape(num_actions, -1).T


def block_features(phi: sp.csr_matrix, num_actions: int) -> sp.csr_matrix:
    """Φ̄ for every (a, s), action-major rows ``a·|S| + s`` (Eq. 2.11 for all pairs)."""
    return sp.csr_matrix(sp.block_diag([phi] * num_actions, format="csr"))


def q_from_weights(phi: sp.csr_matrix, weights: np.ndarray) -> np.ndarray:
    """Q(s_i, ·) = φ(s_i)ᵀθ for every row, shape (L, |A|); ``weights`` is (n, |A|)."""
    return np.asarray(phi @ weights)


def policy_weighting(
    model: TabularModel, policy: np.ndarray, epsilon: float, weighting: str
) -> tuple[np.ndarray, np.ndarray]:
    """Return d(s) and the π^ε(a|s) table used for D and D̄ (Eq. 2.14, Choice in Alg. 3-4).

    d is the steady state of π^ε's chain where termination restarts from the start
    distribution (``steady_state``), or uniform over non-terminal states (``uniform``).
    """
    n, num_actions = model.num_states, model.num_actions
    action_probs = np.full((n, num_actions), epsilon / num_actions)
    action_probs[np.arange(n), policy] += 1.0 - epsilon
    if weighting == "uniform":
        d = (~model.is_terminal).astype(np.float64)
    else:
        chain = sp.csr_matrix((n, n))
        for a in range(num_actions):
            chain = chain + sp.diags(action_probs[:, a]) @ model.transitions[a]
        d = steady_state_distribution(model.restart_matrix(sp.csr_matrix(chain)))
        d[model.is_terminal] = 0.0
    total = d.sum()
    return (d / total if total > 0 else d), action_probs


def sample_trajectory(
    sampler: GenerativeModel,
    choose: Callable[[np.ndarray, np.random.Generator], int],
    num_samples: int,
    rng: np.random.Generator,
    num_next: int = 1,
    max_episode_steps: int | None = None,
) -> dict[str, Any]:
    """Follow ``choose`` (π^ε) for ``num_samples`` steps, restarting at termination.

    The trajectory also restarts after ``max_episode_steps`` steps of one episode (default:
    the sampler's ``spec.max_episode_steps``), so that samples cover more than one region.

    Every visited ⟨s_i, a_i⟩ also gets ``num_next`` independent draws s' ~ P(s_i, a_i); the
    trajectory continues from the first. Returns lists ``states``, ``actions`` and arrays
    ``next_states`` (L, num_next, d), ``rewards`` (L, num_next), ``terminated`` (L, num_next).
    """
    states, actions, nexts, rewards, terminals = [], [], [], [], []
    cap = int(sampler.spec.max_episode_steps if max_episode_steps is None else max_episode_steps)
    state = sampler.sample_start(rng)
    steps = 0
    for _ in range(num_samples):
        action = choose(state, rng)
        draws = [sampler.sample(state, action, rng) for _ in range(num_next)]
        states.append(state)
        actions.append(action)
        nexts.append([d[0] for d in draws])
        rewards.append([d[1] for d in draws])
        terminals.append([d[2] for d in draws])
        steps += 1
        if draws[0][2] or steps >= cap:
            state, steps = sampler.sample_start(rng), 0
        else:
            state = draws[0][0]
    return {
        "states": np.array(states),
        "actions": np.array(actions, dtype=np.int64),
        "next_states": np.array(nexts),
        "rewards": np.array(rewards, dtype=np.float64),
        "terminated": np.array(terminals, dtype=bool),
    }


def epsilon_greedy_chooser(
    representation: Representation, weights: np.ndarray, epsilon: float, num_actions: int
) -> Callable[[np.ndarray, np.random.Generator], int]:
    """π^ε(s) of Eq. 2.27 from Q = θᵀφ(s) (ties to the lowest action)."""

    def choose(state: np.ndarray, rng: np.random.Generator) -> int:
        if rng.random() < epsilon:
            return int(rng.integers(num_actions))
        return int(np.argmax(representation.encode(np.asarray(state, float)).dot(weights)))

    return choose


def setup_representation(
    representation: Representation | None, spec: DomainSpec, seed: int
) -> Representation:
    """Clone and set up ``representation`` (default: `Tabular` with one feature per value)."""
    if representation is None:
        from conjure.representations.tabular import Tabular

        representation = Tabular()
    return representation.clone().setup(spec, seed)


@numba.njit(cache=True, inline="always")
def _row_q(
    weights: np.ndarray,
    indptr: np.ndarray,
    indices: np.ndarray,
    data: np.ndarray,
    row: int,
    action: int,
) -> float:
    """Q(s, a) = φ(s)ᵀθ_a for the CSR row of s."""
    q = 0.0
    for k in range(indptr[row], indptr[row + 1]):
        q += weights[indices[k], action] * data[k]
    return q


@numba.njit(cache=True, inline="always")
def _row_max_q(
    weights: np.ndarray, indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, row: int
) -> float:
    """max_a Q(s, a) for the CSR row of s."""
    best = -np.inf
    for a in range(weights.shape[1]):
        best = max(best, _row_q(weights, indptr, indices, data, row, a))
    return best


@numba.njit(cache=True, inline="always")
def _gradient_step(
    weights: np.ndarray,
    indptr: np.ndarray,
    indices: np.ndarray,
    data: np.ndarray,
    row: int,
    action: int,
    target: float,
    step_size: float,
) -> float:
    """θ_a ← θ_a + αδφ(s) with δ = target − Q(s, a) (Eq. 2.30); returns |δ|."""
    delta = target - _row_q(weights, indptr, indices, data, row, action)
    for k in range(indptr[row], indptr[row + 1]):
        weights[indices[k], action] += step_size * delta * data[k]
    return abs(delta)


@numba.njit(cache=True)
def bellman_sweep(
    indptr: np.ndarray,
    indices: np.ndarray,
    data: np.ndarray,
    rewards: np.ndarray,
    values: np.ndarray,
    new_values: np.ndarray,
    is_terminal: np.ndarray,
    discount: float,
) -> float:
    """One synchronous sweep of Eq. 2.10 over the state-major CSR P; writes ``new_values``.

    Row ``s·|A| + a`` of the CSR is P^a_{s·}; ``rewards`` is (|S|, |A|). Returns
    max_s |V_new(s) − V(s)| (Algorithm 2's checkpoint). V(terminal) stays 0.
    """
    num_states, num_actions = rewards.shape
    largest = 0.0
    for s in range(num_states):
        best = -np.inf
        for a in range(num_actions):
            row = s * num_actions + a
            total = 0.0
            for k in range(indptr[row], indptr[row + 1]):
                total += data[k] * values[indices[k]]
            q = rewards[s, a] + discount * total
            if q > best:
                best = q
        if is_terminal[s]:
            best = 0.0
        new_values[s] = best
        change = abs(best - values[s])
        if change > largest:
            largest = change
    return largest


# ------------------------------------------------------ the sampled planners (Alg 5-9, 13)


def initial_weights(rng: np.random.Generator, num_features: int, num_actions: int) -> np.ndarray:
    """θ₀ of line 1 ("Random()"): U(−10⁻⁶, 10⁻⁶), small enough only to break argmax ties."""
    return rng.uniform(-1e-6, 1e-6, size=(num_features, num_actions))


def encode_samples(representation: Representation, batch: dict[str, Any]) -> dict[str, Any]:
    """Return ``batch`` with Φ̃ (L × n, ``phi``) and the successors' Φ (L·L₂ × n, ``phi_next``).

    Rows of terminal successors are emptied, so every Q(s', ·) read from them is 0.
    """
    num_samples, num_next = batch["rewards"].shape
    phi = feature_matrix(representation, batch["states"])
    flat_next = batch["next_states"].reshape(num_samples * num_next, -1)
    live = (~batch["terminated"].reshape(-1)).astype(np.float64)
    phi_next = sp.csr_matrix(sp.diags(live) @ feature_matrix(representation, flat_next))
    phi_next.eliminate_zeros()
    return {**batch, "phi": phi, "phi_next": phi_next, "num_next": num_next}


def greedy_next_features(
    phi_next: sp.csr_matrix, weights: np.ndarray, num_next: int
) -> sp.csr_matrix:
    """φ(s'_j, π(s'_j)) averaged over the L₂ draws of each sample (Eq. 2.28), in Φ̄ columns.

    π(s') = argmax_a φ(s')ᵀθ_a is computed on demand (Algorithm 6); terminal rows stay empty.
    """
    num_actions = weights.shape[1]
    chosen = np.asarray(phi_next @ weights).argmax(axis=1)
    rows = action_features(phi_next, chosen, num_actions)
    num_samples = rows.shape[0] // num_next
    averaging = sp.kron(sp.identity(num_samples, format="csr"), np.full((1, num_next), 1.0))
    return sp.csr_matrix(averaging @ rows) / num_next


def sampled_backups(data: dict[str, Any], weights: np.ndarray, discount: float) -> np.ndarray:
    """Q⁺(s_i, a_i) = (1/L₂) Σ_j [r_ij + γ max_a' Q(s'_ij, a')] (Algorithms 8-9, line 6)."""
    num_samples, num_next = data["rewards"].shape
    best = np.asarray(data["phi_next"] @ weights).max(axis=1).reshape(num_samples, num_next)
    return (data["rewards"] + discount * best).mean(axis=1)


class SparseRows(NamedTuple):
    """A CSR matrix as the kernels read it: row r holds ``data[indptr[r]:indptr[r + 1]]``.

    The values sit at the columns ``indices[indptr[r]:indptr[r + 1]]``, in stored order.
    """

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray


def sparse_rows(matrix: sp.spmatrix) -> SparseRows:
    """The `SparseRows` of ``matrix`` (its own arrays when it is already CSR)."""
    rows = sp.csr_matrix(matrix)
    return SparseRows(indptr=rows.indptr, indices=rows.indices, data=rows.data)


class Backups(NamedTuple):
    """The pairs ⟨s_i, a_i⟩ one Q-AVI pass updates, with what their Q⁺ reads (Algorithms 7, 8).

    Q⁺_i = (R_i + Σ_k [r_k + γ w_k max_a' Q(s'_k, a')]) / L₂ over the successors k in row i of
    ``successors`` (column: the row of ``next_phi`` holding φ(s'_k); value: w_k). An empty row
    of ``next_phi`` (a terminal s') has max_a' Q = 0.
    """

    states: np.ndarray  # row of φ per pair
    actions: np.ndarray
    rewards: np.ndarray  # R_i
    successors: SparseRows
    successor_rewards: np.ndarray  # r_k
    next_phi: SparseRows
    num_draws: int  # L₂


def model_backups(model: TabularModel, phi: sp.csr_matrix) -> Backups:
    """Every non-terminal (s, a), s-major, with Q⁺ = R(s, a) + Σ_s' γP^a_{ss'} max_a' Q (Alg 7).

    Lines 3-5 of Algorithm 7; ``phi`` is Φ over the model's states (`state_features`).
    """
    num_actions = model.num_actions
    pairs = np.flatnonzero(np.repeat(~model.is_terminal, num_actions))  # row s·|A| + a
    states, actions = pairs // num_actions, pairs % num_actions
    successors = sparse_rows(model.state_major_transitions[pairs])
    return Backups(
        states=states,
        actions=actions,
        rewards=np.ascontiguousarray(model.rewards[states, actions]),
        successors=successors,
        successor_rewards=np.zeros(successors.data.shape[0]),
        next_phi=sparse_rows(phi),
        num_draws=1,
    )


def drawn_backups(data: dict[str, Any]) -> Backups:
    """The L₁ sampled pairs, Q⁺ = (1/L₂) Σ_j [r_ij + γ max_a' Q(s'_ij, a')] (Alg 8, line 6).

    ``data`` is an `encode_samples` batch: sample i is row i of Φ̃, its draws rows
    i·L₂ .. i·L₂ + L₂ − 1 of Φ(s').
    """
    num_samples, num_next = data["rewards"].shape
    draws = np.arange(num_samples * num_next)
    return Backups(
        states=np.arange(num_samples),
        actions=data["actions"],
        rewards=np.zeros(num_samples),
        successors=SparseRows(
            indptr=np.arange(0, draws.size + 1, num_next), indices=draws, data=np.ones(draws.size)
        ),
        successor_rewards=np.ascontiguousarray(data["rewards"]).reshape(-1),
        next_phi=sparse_rows(data["phi_next"]),
        num_draws=num_next,
    )


@numba.njit(cache=True)
def q_avi_pass(
    weights: np.ndarray, phi: SparseRows, backups: Backups, discount: float, step_size: float
) -> float:
    """One pass of Q-AVI over ``backups``' pairs in order, θ̄ updated in place; max |δ|.

    Geramifard (2012), Algorithm 7 lines 3-7 (every pair, Q⁺ over P) and Algorithm 8 lines
    4-8 (sampled pairs, Q⁺ over L₂ draws): Q⁺ as in `Backups`, δ = Q⁺ − Q(s_i, a_i), and
    θ̄ ← θ̄ + αδφ(s_i, a_i) (Eq. 2.30), each pair reading the θ̄ its predecessors updated.
    """
    successors, next_phi = backups.successors, backups.next_phi
    largest = 0.0
    for i in range(backups.actions.shape[0]):
        target = backups.rewards[i]
        for k in range(successors.indptr[i], successors.indptr[i + 1]):  # Q⁺ (Alg 7 line 5)
            row = successors.indices[k]
            best = 0.0
            if next_phi.indptr[row + 1] > next_phi.indptr[row]:
                best = _row_max_q(weights, next_phi.indptr, next_phi.indices, next_phi.data, row)
            target += backups.successor_rewards[k] + discount * successors.data[k] * best
        target /= backups.num_draws
        change = _gradient_step(  # δ, θ̄ += αδφ(s, a) (Alg 7 lines 6-7, Eq. 2.30)
            weights,
            phi.indptr,
            phi.indices,
            phi.data,
            backups.states[i],
            backups.actions[i],
            target,
            step_size,
        )
        largest = max(largest, change)
    return largest


def state_features(model: TabularModel, representation: Representation) -> sp.csr_matrix:
    """Φ over the model's states with terminal rows emptied (Q(terminal, ·) = 0)."""
    phi = sp.csr_matrix(
        sp.diags((~model.is_terminal).astype(np.float64))
        @ feature_matrix(representation, model.states)
    )
    phi.eliminate_zeros()
    return phi


def linear_plan(
    spec: DomainSpec,
    model: TabularModel | None,
    representation: Representation,
    weights: np.ndarray,
    loop: Iterations,
) -> Plan:
    """A `Plan` from θ (n × |A|); with a model, also the greedy π and Q over its states."""
    policy = q_values = None
    if model is not None:
        q_values = q_from_weights(state_features(model, representation), weights)
        policy = q_values.argmax(axis=1).astype(np.int64)
    return loop.plan(
        spec,
        model=model,
        policy=policy,
        q_values=q_values,
        representation=representation,
        weights=weights,
    )
