"""Which (domain, agent) pairs the compiled loop runs, read from the components' compiled forms.

Every part must give a compiled form (`conjure.core.compiled_form`): the domain, the agent
(which asks its policy and step-size schedules), and the agent's representation. A part with
none, or a subclass that overrides a method its kernel stands in for, sends the run to the
Python path; `why_not_compiled` names the first such part.

Covered today (Geramifard 2012): the domains `InvertedPendulum`, `GridWorld`, `ChainMDP`,
`BlocksWorld`, `PersistentSurveillance`, `RescueMission`, `UAVMission`, and any Gymnasium
environment through `GymnasiumDomain` (its own ``step`` called back); the representations
`TileCoding` (hashed or not), `Tabular`, `HashedTabular`, `IndependentDiscretization`,
`BinaryIndicators`, `RBF` (real-valued φ, Section 3.1.2), online iFDD (`OnlineIFDD` and
`RandomExpansion`, Algorithms 19-21) over a binary base, and `ARiFDD` (Algorithm 22); the
learners `SARSA` (with or without traces), `QLearning` and `ActorCritic` (Algorithm 12 as
printed, or with a V critic and the log-policy actor, with the actor sharing the critic's
features; with eligibility traces on fixed features); the policies `EpsilonGreedy`, `Gibbs`;
the schedules `ConstantStepSize`, `FeatureNormalizedDecay`, `EpisodicDecay`; and the iCCA
boxes around such a learner (`CooperativeActorCritic`, Algorithm 23; `CooperativeLearner`
with SARSA or Q-Learning, Algorithm 24, also around online iFDD or ARiFDD;
`AdaptiveCooperativeLearner`, Algorithm 26) when π^p can be tabulated per state (grid
worlds: value iteration on a static model, shortest-path or switching planners) with the
nominal rule or Monte-Carlo rollouts in the tabular T̂, or on UAV missions with CBBA and the
fuel rule or Monte-Carlo rollouts (`conjure.safety.compiled_cooperative`).
The same loop plays the policy checks' greedy episodes (``learn=False``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from conjure.agents.compiled_agent import AgentKernel
from conjure.core.compiled_form import compiled_form
from conjure.core.interfaces import Agent, Domain, check_is_set_up
from conjure.representations.compiled_ifdd import IFDDKernel, fixed
from conjure.safety.compiled_cooperative import CompiledBox, alone

__all__ = [
    "Selection",
    "box_form",
    "learner_of",
    "representation_form",
    "select",
    "why_not_compiled",
]


@dataclass(frozen=True)
class Selection:
    """A pair the compiled loop runs.

    ``max_episode_steps``: the episode cap; ``is_real_valued``: whether φ has real values
    (`RBF`: the loop's second compilation).
    """

    max_episode_steps: int
    is_real_valued: bool


def select(domain: Domain, agent: Agent) -> Selection | str:
    """The `Selection` of a set-up ``agent`` on ``domain``, or why a part has no kernel.

    Raises
    ------
    NotSetUpError
        If ``agent.setup`` has not run.
    """
    domain_form = compiled_form(domain)
    if domain_form is None:
        return f"the domain {type(domain).__name__} has no compiled kernel"
    if not hasattr(agent, "compiled_form"):
        return f"the agent {type(agent).__name__} has no compiled kernel"
    check_is_set_up(agent, "select")
    learner = learner_of(agent)
    if learner is not agent and compiled_form(agent) is None:
        return _no_variant(agent)
    parts = (("policy", learner.policy_), ("step-size schedule", learner.schedule_))
    for part, component in parts:
        if compiled_form(component) is None:
            return f"the {part} {type(component).__name__} has no compiled kernel"
    if compiled_form(learner) is None:
        return _no_variant(learner)
    rep = representation_form(learner)
    if rep is None:
        name = type(learner.representation_).__name__
        return f"the representation {name} has no compiled kernel here"
    return Selection(domain.domain_spec.max_episode_steps, rep.base.rbf is not None)


def _no_variant(component: Any) -> str:
    variant = getattr(component, "compiled_variant", "")
    return f"{type(component).__name__} with these parameters has no compiled kernel" + (
        f" ({variant})" if variant else ""
    )


def learner_of(agent: Agent) -> Agent:
    """The learner whose kernels run: the agent, or the one inside a cooperative box.

    A box (`conjure.safety.CooperativeActorCritic`) names it ``compiled_learner``.
    """
    return getattr(agent, "compiled_learner", agent)


def box_form(agent: Agent, rep: IFDDKernel) -> CompiledBox:
    """The agent's box (`conjure.safety.compiled_cooperative`), `NO_BOX` for a learner alone.

    A box's form is its kept state; a policy check acts with its ``greedy_parts`` (its
    analyser draws from the agent's ``eval_rng_``).
    """
    if learner_of(agent) is agent:
        return alone(rep.base)
    form = compiled_form(agent)
    assert form is not None  # `select` checked it
    return form


def why_not_compiled(domain: Domain, agent: Agent) -> str | None:
    """Name the first part of a set-up ``agent`` on ``domain`` with no compiled kernel.

    ``None`` when every part has one (then `select` returns a `Selection`).
    """
    selected = select(domain, agent)
    return None if isinstance(selected, Selection) else selected


def representation_form(agent: Agent) -> IFDDKernel | None:
    """The agent's representation as the loop's growing-representation argument, or None."""
    form = compiled_form(agent.representation_)
    if form is None or isinstance(form, IFDDKernel):
        return form
    return fixed(form)


def agent_form(agent: Agent) -> AgentKernel:
    """The agent's compiled form (selected agents always have one)."""
    form = compiled_form(agent)
    assert form is not None  # `select` checked it
    return form
