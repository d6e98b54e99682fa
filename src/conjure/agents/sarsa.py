"""SARSA and SARSA(λ), Geramifard (2012), Algorithm 11 (Rummery and Niranjan 1994)."""

from __future__ import annotations

import numpy as np

from conjure.agents import compiled_agent as forms
from conjure.agents import persistence
from conjure.agents.constraints import CostConstraint
from conjure.agents.linear_td import LinearTDAgent
from conjure.core.interfaces import (
    DomainSpec,
    Policy,
    Representation,
)
from conjure.core.params import Interval, Options
from conjure.core.schedules import StepSizeSchedule

__all__ = ["SARSA"]


class SARSA(LinearTDAgent):
    """On-policy TD control: Q⁺(s, a) = r + γ Q(s', a') with a' = π^ε(s') (Algorithm 11).

    Parameters
    ----------
    representation : Representation
        φ, read through its `encode`: binary features or real-valued ones (Gaussian RBF).
    policy : Policy or None, default None
        The behaviour policy π^ε; ``None`` means ``EpsilonGreedy(epsilon=0.1)`` (Section 4.1.4).
    step_size : float or StepSizeSchedule, default 0.1
        α in (0, 10], or a schedule such as `FeatureNormalizedDecay` (Section 4.1.4).
    trace_decay : float, default 0.0
        λ in [0, 1]; 0 is Algorithm 11 as written, > 0 adds eligibility traces (SARSA(λ)).
    trace_kind : {"replacing", "accumulating"}, default "replacing"
        How the traces of φ(s)'s features are refreshed; a φ(s) with values other than 1
        always accumulates.
    min_trace : float, default 1e-3
        Traces that decay below this are dropped, in (0, 1).
    initial_weight : float, default 0.0
        θ's initial value.
    constraint : CostConstraint or None, default None
        A cost limit per episode and its multiplier rule (`Lagrangian`, `PIDLagrangian`;
        `conjure.agents.constraints`): a cost critic θ_C and λ.

    Attributes
    ----------
    weights_ : ndarray of shape (n_features, n_actions)
        θ; row f holds feature f's weight for every action (φ(s, a) of Eq. 2.11).
    representation_ : Representation
        The set-up copy of ``representation``.
    episode_ : int
        Episodes begun, the schedules' ``Episode #``.

    Notes
    -----
    Symbols: θ ``weights_``, φ(s) ``representation_.encode``, α ``step_size``,
    δ the TD error returned by ``learn``, λ ``trace_decay``, γ the domain's discount.

    - Choice: θ starts at ``initial_weight`` (zero by default) where Algorithm 11 writes
      θ ← Random(); zero keeps runs comparable and Q finite from the first step.
    - Choice: with traces, binary features use replacing traces by default (Singh and Sutton
      1996); traces are cleared at the start of each episode and stored sparsely, so a step
      costs Θ(number of live traces), never Θ(n).
    - Choice: replacing traces, e(i, a) ← φ_i(s), are defined for binary features (Singh and
      Sutton 1996); when a φ(s) holds any value other than 1 (Gaussian RBF) that step
      accumulates, e(i, a) ← γλ e(i, a) + φ_i(s), whatever ``trace_kind`` says.
    - Choice: real-valued features (RBF) use the same sparse traces, so their traces below
      ``min_trace`` are dropped too. Earlier conjure kept dense, never dropped traces for
      them, so SARSA(λ) with RBF differs from those runs only by the dropped traces; an
      agent saved with such a dense ``traces`` array is restored with its non-zero entries.

    Complexity
    ----------
    Θ(k|A|) per step for k active features (Algorithm 11: Θ(n|A|) with dense φ).

    Examples
    --------
    >>> from conjure.domains import ChainMDP
    >>> from conjure.experiments import run
    >>> from conjure.representations import Tabular
    >>> agent = SARSA(representation=Tabular(), step_size=0.5)
    >>> result = run(domain=ChainMDP(), agent=agent, budget_steps=500, seed=0)
    >>> int(result.curve["learning_steps"].iloc[-1])
    500
    """

    parameter_constraints = {
        **LinearTDAgent.parameter_constraints,
        "trace_decay": Interval(float, 0, 1),
        "trace_kind": Options(("replacing", "accumulating")),
        "min_trace": Interval(float, 0, 1, closed="neither"),
    }

    kernel_kind = forms.SARSA

    def __init__(
        self,
        *,
        representation: Representation,
        policy: Policy | None = None,
        step_size: float | StepSizeSchedule = 0.1,
        trace_decay: float = 0.0,
        trace_kind: str = "replacing",
        min_trace: float = 1e-3,
        initial_weight: float = 0.0,
        constraint: CostConstraint | None = None,
    ):
        self.representation = representation
        self.policy = policy
        self.step_size = step_size
        self.trace_decay = trace_decay
        self.trace_kind = trace_kind
        self.min_trace = min_trace
        self.initial_weight = initial_weight
        self.constraint = constraint

    def _set_up_learner(self, spec: DomainSpec) -> None:
        """The eligibility traces when λ > 0: γλ, their kind and the smallest kept."""
        self._has_traces = self.trace_decay > 0
        self._trace_factor = self.discount_ * self.trace_decay

    @property
    def compiled_irrelevant_params(self) -> frozenset[str]:
        """θ's initial value (folded into θ at setup); without traces, their kind and floor."""
        unused = {"trace_kind", "min_trace"} if self.trace_decay == 0 else set()
        return frozenset({"initial_weight", *unused})

    def _make_kernel(self) -> forms.AgentKernel:
        """SARSA(λ)'s `AgentKernel`: γλ, the trace kind and the smallest trace kept."""
        if not self._has_traces:
            return self._kernel(forms.SARSA)
        kind = forms.REPLACING if self.trace_kind == "replacing" else forms.ACCUMULATING
        return self._kernel(forms.SARSA, kind, self._trace_factor, float(self.min_trace))

    def _initial_arrays(self, spec: DomainSpec) -> forms.LearnerArrays:
        """θ and, with λ > 0, empty sparse traces (`td_step_traces`' arrays)."""
        arrays = super()._initial_arrays(spec)
        if not self._has_traces:
            return arrays
        return arrays._replace(**_new_traces(arrays.weights.shape))

    # ------------------------------------------------------------------ eligibility traces

    @property
    def trace_slots_(self) -> np.ndarray:
        """1 + the slot of trace (f, a), 0 for none: the rows of the features in use."""
        return self.arrays_.trace_slots[: self.representation_.num_features_]

    @property
    def trace_features_(self) -> np.ndarray:
        """The features of the live traces (the first ``trace_count_[0]`` slots)."""
        return self.arrays_.trace_features

    @property
    def trace_actions_(self) -> np.ndarray:
        """The actions of the live traces."""
        return self.arrays_.trace_actions

    @property
    def trace_values_(self) -> np.ndarray:
        """The values of the live traces."""
        return self.arrays_.trace_values

    @property
    def trace_count_(self) -> np.ndarray:
        """The number of live traces, in a one-element array."""
        return self.arrays_.trace_count

    def grow_trace_capacity(self) -> None:
        """Double the room of the sparse traces (the compiled loop asks before it overflows)."""
        arrays = self.arrays_
        extra = arrays.trace_values.shape[0]
        self._set_arrays(
            arrays._replace(
                trace_features=np.concatenate([arrays.trace_features, np.zeros(extra, np.int64)]),
                trace_actions=np.concatenate([arrays.trace_actions, np.zeros(extra, np.int64)]),
                trace_values=np.concatenate([arrays.trace_values, np.zeros(extra)]),
            )
        )

    def _grown_arrays(self) -> tuple[bool, bool]:
        return False, self._has_traces  # a new feature's trace slots start empty

    # ------------------------------------------------------------------ persistence

    def state_arrays(self) -> dict[str, np.ndarray]:
        arrays = super().state_arrays()
        if self._has_traces:
            count = int(self.trace_count_[0])
            arrays["trace_features"] = self.trace_features_[:count]
            arrays["trace_actions"] = self.trace_actions_[:count]
            arrays["trace_values"] = self.trace_values_[:count]
        return arrays

    def load_state(self, saved: persistence.SavedAgent) -> None:
        super().load_state(saved)
        if not self._has_traces:
            return
        n, num_actions = self.weights_.shape
        self._set_arrays(self.arrays_._replace(**_new_traces((n, num_actions))))
        if "traces" in saved.arrays:  # the dense layout of earlier saves (RBF, λ > 0)
            dense = saved.array("traces", (n, num_actions))
            features, actions = np.nonzero(dense)
            values = dense[features, actions]
            count = features.shape[0]
        else:
            features = saved.indices("trace_features", (None,), n)
            count = features.shape[0]
            actions = saved.indices("trace_actions", (count,), num_actions)
            values = saved.array("trace_values", (count,))
        if np.unique(features * num_actions + actions).shape[0] != count:
            raise saved.damaged("arrays.npz", "two eligibility traces share a (feature, action)")
        while self.trace_values_.shape[0] < count:
            self.grow_trace_capacity()
        self.trace_features_[:count] = features
        self.trace_actions_[:count] = actions
        self.trace_values_[:count] = values
        self.trace_slots_[features, actions] = np.arange(1, count + 1)
        self.trace_count_[0] = count


def _new_traces(shape: tuple[int, int]) -> dict[str, np.ndarray]:
    """Empty sparse traces for θ of ``shape``: slots per (feature, action), room for 1024."""
    capacity = 1024
    return {
        "trace_slots": np.zeros(shape, dtype=np.int64),  # 1 + slot; 0: none
        "trace_features": np.zeros(capacity, dtype=np.int64),
        "trace_actions": np.zeros(capacity, dtype=np.int64),
        "trace_values": np.zeros(capacity),
        "trace_count": np.zeros(1, dtype=np.int64),
    }
