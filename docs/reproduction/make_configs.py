"""Write the sweep configs in examples/reproduction/ (from any working directory).

Chapters 3-4: ``fig_3_*``/``fig_4_*``; chapter 5 (safe exploration, iCCA): ``fig_5_*``.

python docs/reproduction/make_configs.py
python docs/reproduction/make_configs.py --out DIR   # write them under DIR instead
"""

import copy
import csv
import sys
from pathlib import Path

import yaml

OUT = Path(__file__).resolve().parents[2] / "examples" / "reproduction"
KINDS = {
    "pendulum": "InvertedPendulum",
    "blocksworld": "BlocksWorld",
    "surveillance": "PersistentSurveillance",
    "rescue": "RescueMission",
}
# initial features (Section 4.1.4): 20 buckets per pendulum dimension, On(.,.) indicators on
# BlocksWorld, one indicator per value of each state variable on the UAV domains
BASE = {
    "pendulum": {"kind": "IndependentDiscretization", "params": {"num_buckets": 20}},
    "blocksworld": {"kind": "BinaryIndicators", "params": {}},
    "surveillance": {"kind": "IndependentDiscretization", "params": {}},
    "rescue": {"kind": "IndependentDiscretization", "params": {}},
}
# step sizes: the tuned settings of examples/pendulum.yaml, blocksworld.yaml and
# persistent_surveillance.yaml; the Rescue Mission has no example and gets a small grid
STEP = {
    "pendulum": (1.0, 100),
    "blocksworld": (0.1, 100),
    "surveillance": (1.0, 1000),
    "rescue": (1.0, 1000),
}
BLOCKS_INITIAL_STEP = (1.0, 100)
# BlocksWorld's tabular learner indexes the states it meets (HashedTabular): the thesis's
# 368,316 state-action pairs over 36 actions are 10,231 states, of which 4,051 are reachable
BLOCKS_TABULAR = {"kind": "HashedTabular", "params": {"capacity": 10231}}
# iFDD+ in both forms: RLPy's |Delta_f| / sqrt(nu_f) and Eq. 4.3 as printed, Delta_f / sqrt(nu_f)
IFDD_PLUS_FORMS = ("ifdd_plus", "ifdd_plus_signed")
# Fig. 4-7 on the Rescue Mission: alpha_0 = 0.1, the value Fig. 4-5's selection chose there
# for the initial features, iFDD and iFDD+
FIXED_RATE_STEP = {"rescue": (0.1, 1000)}  # examples/blocksworld.yaml's `initial`
# discovery thresholds: iFDD+ (both forms) from the thesis's candidate sets (Section 4.1.4);
# iFDD (Eq. 4.2, sum of |delta|) on larger values, as the thesis says iFDD+'s candidates were
# smaller. The first runs offered iFDD two values and it picked the larger everywhere, so the
# grid goes one to two decades higher.
IFDD_XI = {
    "pendulum": [0.2, 1.0, 5.0],
    "blocksworld": [0.2, 1.0, 5.0],
    "surveillance": [300.0, 3000.0, 30000.0],
    "rescue": [10.0, 100.0, 1000.0, 10000.0],
}
IFDD_PLUS_XI = {
    "pendulum": [0.02, 0.05, 0.1],
    "blocksworld": [0.02, 0.05, 0.1],
    "surveillance": [50.0, 100.0, 200.0],
    "rescue": [100.0, 200.0, 500.0],
}
# evaluation episodes per policy check: pendulum episodes last up to 3,000 steps, Rescue
# Mission episodes 10 steps (and its returns are noisy)
FRESH_SEEDS = {"pendulum": 30, "blocksworld": 30, "surveillance": 30, "rescue": 20}
EVAL_EPISODES = {"pendulum": 2, "blocksworld": 5, "surveillance": 5, "rescue": 50}
C = {"pendulum": 0.2, "blocksworld": 0.4, "surveillance": 2.0, "rescue": 0.004}


def sarsa(rep, step):
    """Return a SARSA agent spec with representation ``rep`` and (alpha_0, N_0) ``step``."""
    alpha_0, n_0 = step
    return {
        "kind": "SARSA",
        "params": {
            "representation": rep,
            "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 0.1}},
            "step_size": {
                "kind": "FeatureNormalizedDecay",
                "params": {"alpha_0": alpha_0, "n_0": n_0},
            },
        },
    }


def write(name, header, config):
    """Write ``config`` with a comment ``header`` to examples/reproduction/NAME.yaml."""
    text = header + yaml.safe_dump(config, sort_keys=False, width=100)
    (OUT / f"{name}.yaml").write_text(text)


def fig_4_5():
    """Figs. 4-4, 4-5, 4-8, 4-9: one sweep per domain (agents differ per domain)."""
    for domain, kind in KINDS.items():
        step, base = STEP[domain], BASE[domain]
        agents = {
            "initial": sarsa(base, BLOCKS_INITIAL_STEP if domain == "blocksworld" else step),
            "ifdd": sarsa(
                {
                    "kind": "OnlineIFDD",
                    "params": {
                        "base": base,
                        "relevance": "ifdd",
                        "discovery_threshold": IFDD_XI[domain][0],
                    },
                },
                step,
            ),
            **{
                form: sarsa(
                    {
                        "kind": "OnlineIFDD",
                        "params": {
                            "base": base,
                            "relevance": form,
                            "discovery_threshold": IFDD_PLUS_XI[domain][0],
                        },
                    },
                    step,
                )
                for form in IFDD_PLUS_FORMS
            },
            "atc": sarsa({"kind": "AdaptiveTileCoding", "params": {}}, step),
        }
        if domain == "blocksworld":  # Tabular would allocate all 2^36 cells
            agents["tabular"] = sarsa(BLOCKS_TABULAR, step)
        else:
            agents["tabular"] = sarsa({"kind": "Tabular", "params": {}}, step)
        if domain == "pendulum":
            agents["sdm"] = sarsa({"kind": "SparseDistributedMemory", "params": {}}, step)
            agents["rbf"] = sarsa({"kind": "RBF", "params": {"num_centers": 9}}, step)
        else:
            # the default radius 0.1 builds a 5^d covering grid (OOM on 12-13 dims)
            agents["sdm"] = sarsa(
                {"kind": "SparseDistributedMemory", "params": {"activation_radius": 0.5}}, step
            )
        grid = {"agents.ifdd.params.representation.params.discovery_threshold": IFDD_XI[domain]}
        for form in IFDD_PLUS_FORMS:
            key = f"agents.{form}.params.representation.params.discovery_threshold"
            grid[key] = IFDD_PLUS_XI[domain]
        if domain == "blocksworld":  # tabular is neither the initial nor an expanding method
            grid["agents.tabular.params.step_size.params.alpha_0"] = [0.1, 1.0]
        if domain == "rescue":
            for label in agents:
                grid[f"agents.{label}.params.step_size.params.alpha_0"] = [0.1, 1.0]
        config = {
            "name": f"fig_4_5_{domain}",
            "domain": {"kind": kind, "params": {}},
            "agents": agents,
            "grid": grid,
            "budget_steps": 100000,
            "num_policy_checks": 10,
            "eval_episodes": EVAL_EPISODES[domain],
            "seeds": 3,
            "metric": "episode_length" if domain == "pendulum" else "return",
            "selection": {"criterion": "auc", "mode": "max", "fresh_seeds": FRESH_SEEDS[domain]},
        }
        header = (
            f"# Geramifard 2012, Figs. 4-4, 4-5, 4-8 and 4-9 on {kind} (generated by\n"
            "# docs/reproduction/make_configs.py). SARSA, epsilon = 0.1, step sizes alpha_0/k_t\n"
            "# (N_0+1)/(N_0+episode^1.1) from the tuned examples; discovery thresholds chosen by\n"
            f"# mean AUC on seeds 0-2, then reported on {FRESH_SEEDS[domain]} fresh seeds.\n"
        )
        write(f"fig_4_5_{domain}", header, config)


def fig_4_7():
    """Fig. 4-7: iFDD vs random expansion at the fixed discovery rate of Eq. 4.6."""
    for domain, kind in KINDS.items():
        step, base = FIXED_RATE_STEP.get(domain, STEP[domain]), BASE[domain]
        agents = {
            "ifdd_fixed_rate": sarsa(
                {
                    "kind": "OnlineIFDD",
                    "params": {"base": base, "relevance": "ifdd", "discovery_rate": C[domain]},
                },
                step,
            ),
            "random_fixed_rate": sarsa(
                {"kind": "RandomExpansion", "params": {"base": base, "discovery_rate": C[domain]}},
                step,
            ),
        }
        config = {
            "name": f"fig_4_7_{domain}",
            "domain": {"kind": kind, "params": {}},
            "agents": agents,
            "budget_steps": 100000,
            "num_policy_checks": 10,
            "eval_episodes": EVAL_EPISODES[domain],
            "seeds": list(range(100, 130)),
            "metric": "episode_length" if domain == "pendulum" else "return",
        }
        header = (
            f"# Geramifard 2012, Fig. 4-7 on {kind}: iFDD vs random expansion at the same\n"
            f"# fixed discovery rate n_t = n_0 + sqrt(C t), C = {C[domain]} (Eq. 4.6).\n"
            "# Generated by docs/reproduction/make_configs.py.\n"
        )
        write(f"fig_4_7_{domain}", header, config)


def fig_4_11():
    """Fig. 4-11: ARiFDD, iFDD, initial and tabular across initial tiles per dimension."""
    tiles = [1, 2, 3, 4, 5, 6, 10]
    step = STEP["pendulum"]
    agents = {
        "arifdd": sarsa(
            {
                "kind": "ARiFDD",
                "params": {
                    "initial_tiles_per_dim": 2,
                    "relevance": "ifdd",
                    "discovery_threshold": 1.0,
                    "split_threshold": 1.0,
                    "min_tile_fraction": 0.05,
                },
            },
            step,
        ),
        "ifdd": sarsa(
            {
                "kind": "OnlineIFDD",
                "params": {
                    "base": {"kind": "IndependentDiscretization", "params": {"num_buckets": 2}},
                    "relevance": "ifdd",
                    "discovery_threshold": 1.0,
                },
            },
            step,
        ),
        "initial": sarsa({"kind": "IndependentDiscretization", "params": {"num_buckets": 2}}, step),
        "tabular": sarsa({"kind": "Tabular", "params": {"num_buckets": 2}}, step),
    }
    config = {
        "name": "fig_4_11",
        "domain": {"kind": "InvertedPendulum", "params": {}},
        "agents": agents,
        "grid": {
            "agents.arifdd.params.representation.params.initial_tiles_per_dim": tiles,
            "agents.ifdd.params.representation.params.base.params.num_buckets": tiles,
            "agents.initial.params.representation.params.num_buckets": tiles,
            "agents.tabular.params.representation.params.num_buckets": tiles,
        },
        "budget_steps": 100000,
        "num_policy_checks": 10,
        "eval_episodes": 2,
        "seeds": list(range(100, 116)),
        "metric": "episode_length",
    }
    header = (
        "# Geramifard 2012, Fig. 4-11: SARSA with ARiFDD, iFDD, initial and tabular features on\n"
        "# the inverted pendulum, across the number of uniform tiles per dimension of the\n"
        "# initial features (varsigma = 1, no split below 1/20 of a dimension). Generated by\n"
        "# docs/reproduction/make_configs.py.\n"
    )
    write("fig_4_11", header, config)


# investigations of the results that did not reproduce (docs/reproduction/fig_4_5.md, "Why ...")
INVESTIGATION_SEEDS = list(range(300, 320))
XI = "params.discovery_threshold"
# the Rescue Mission's initial features without the time step t (dimension 12): one tile
# per value of each of the other 12 dimensions, i.e. IndependentDiscretization minus t
RESCUE_NO_TIME = {
    "kind": "TileCoding",
    "params": {"num_tilings": 1, "dimension_groups": [[i] for i in range(12)]},
}


def investigate(name, header, domain, agents, seeds, grid=None, domain_params=None):
    """Write one investigation sweep (no selection: every setting on the same seeds)."""
    config = {
        "name": name,
        "domain": {"kind": KINDS[domain], "params": domain_params or {}},
        "agents": agents,
        "budget_steps": 100000,
        "num_policy_checks": 10,
        "eval_episodes": EVAL_EPISODES[domain],
        "seeds": seeds,
        "metric": "return",
    }
    if grid:
        config["grid"] = grid
    write(name, header + "# Generated by docs/reproduction/make_configs.py.\n", config)


def ifdd(base, threshold, relevance="ifdd"):
    """An OnlineIFDD spec over ``base``."""
    params = {"base": base, "relevance": relevance, "discovery_threshold": threshold}
    return {"kind": "OnlineIFDD", "params": params}


def investigations():
    """Sweeps testing the causes of Fig. 4-5(c)/(d)'s differences from the thesis."""
    base, slow = BASE["rescue"], FIXED_RATE_STEP["rescue"]
    investigate(
        "investigate_rescue_no_time",
        "# Rescue Mission: initial features and iFDD without the time step t, which the\n"
        "# thesis's feature list (fuel, position, comm mode, rescue status) does not name;\n"
        "# 5 seeds.\n",
        "rescue",
        {
            "initial_no_t": sarsa(RESCUE_NO_TIME, slow),
            "ifdd_no_t": sarsa(ifdd(RESCUE_NO_TIME, 100.0), slow),
        },
        INVESTIGATION_SEEDS[:5],
        {f"agents.ifdd_no_t.params.representation.{XI}": IFDD_XI["rescue"][1:]},
    )

    step_grid = {
        f"agents.{label}.params.step_size.params.{name}": values
        for label in ("initial", "ifdd")
        for name, values in (("alpha_0", [0.01, 0.1, 1.0]), ("n_0", [100, 1000, 1000000]))
    }
    investigate(
        "investigate_rescue_step_size",
        "# Rescue Mission: the thesis's full step-size grid, alpha_0 in {0.01, 0.1, 1} x N_0 in\n"
        "# {100, 1000, 1e6}, for the initial features and iFDD (xi = 1000), 5 seeds.\n",
        "rescue",
        {"initial": sarsa(base, slow), "ifdd": sarsa(ifdd(base, 1000.0), slow)},
        INVESTIGATION_SEEDS[:5],
        step_grid,
    )
    surveillance_step = STEP["surveillance"]
    investigate(
        "investigate_surveillance_step_size",
        "# Persistent Surveillance: the thesis's full step-size grid, alpha_0 in {0.01, 0.1, 1}\n"
        "# x N_0 in {100, 1000, 1e6}, for the initial features and iFDD (xi = 3000), 3 seeds.\n",
        "surveillance",
        {
            "initial": sarsa(BASE["surveillance"], surveillance_step),
            "ifdd": sarsa(ifdd(BASE["surveillance"], 3000.0), surveillance_step),
        },
        INVESTIGATION_SEEDS[:3],
        step_grid,
    )


# issue-9 rerun: the thesis's iFDD+ on the pendulum (Figs. 4-8/4-9), a separate sweep so the
# figure's full sweep need not be rerun (Fig. 4-11's split-rank comparison ran at 60b1102)
def fig_4_8_pendulum_ifdd_plus():
    """Figs. 4-8/4-9 on the pendulum: iFDD+ as Eq. 4.3 prints it, signed Delta_f/sqrt(nu_f).

    Only the signed form runs: RLPy's |Delta_f| form is fig_4_5_pendulum.yaml's ``ifdd_plus``,
    whose runs this sweep would repeat exactly (same run specs and seeds).
    """
    full = yaml.safe_load((OUT / "fig_4_5_pendulum.yaml").read_text())
    form = "ifdd_plus_signed"
    config = {
        **full,
        "name": "fig_4_8_pendulum_ifdd_plus",
        "agents": {form: full["agents"][form]},
        "grid": {k: v for k, v in full["grid"].items() if k.split(".")[1] == form},
        "selection": {**full["selection"], "fresh_seeds": 20},
    }
    header = (
        "# Geramifard 2012, Figs. 4-8/4-9 on InvertedPendulum: the signed iFDD+ row of\n"
        "# fig_4_5_pendulum.yaml alone (Eq. 4.3 as printed, Delta_f/sqrt(nu_f)), threshold\n"
        "# selected on seeds 0-2, reported on 20 fresh seeds. Generated by\n"
        "# docs/reproduction/make_configs.py.\n"
    )
    write("fig_4_8_pendulum_ifdd_plus", header, config)


# ---------------------------------------------------------------------------------------------
# Chapter 5: safe exploration (iCCA). Section 5.3.5: alpha_t = alpha_0 (N_0 + 1)/(N_0 + episode)
# with alpha_0 in {0.01, 0.1, 1} and N_0 in {100, 1000, 1e6} chosen per algorithm and scenario;
# lambda = 100, tau = 1 (actor); epsilon = 0.1 (SARSA); K from {10, 20, 50} (Sections 5.4.1,
# 5.5.2); M = 5 rollouts, risk tolerance 0.2, prior noise 0.4 with weight 100 (Section 5.5.2).

ALPHA_0 = [0.01, 0.1, 1.0]
N_0 = [100, 1000, 1000000]
KNOWN = [10, 20, 50]
# UAV missions: HashedTabular with room for every state 1e5 steps can visit
UAV_INDEX = {"kind": "HashedTabular", "params": {"capacity": 200000}}
GRID_INDEX = {"kind": "Tabular", "params": {}}
GRID_1 = {"map_name": "gridworld1", "step_reward": -0.001, "noise": 0.3}
GRID_2 = {"map_name": "gridworld2", "step_reward": -0.01, "noise": 0.2}
# iCCA that learns past its planner (CooperativeActorCritic, label `icca`): an actor-critic
# with a V critic, the log-policy actor step with its own step size and eligibility traces,
# and a planner bias that fades with the state's visits, lambda N_b / (N_b + n) with lambda =
# 30, N_b = 2 (selected on Fig. 5-5's first search over lambda in {3, 10, 30} x N_b in
# {2, 5, 20}, 5 search seeds, by AUC: chapter5/fig_5_5_bias_search.csv, the selection.csv of
# commit 089835b, whose `icca` was the first variant below). `icca_features`: that first
# variant (V critic, Algorithm 12's actor step, no
# traces); `icca_printed`: Algorithm 23 as printed.
BIAS, HALF_LIFE = 30.0, 2.0
ACTOR_ALPHA_0 = [0.0001, 0.001, 0.01, 0.1, 1.0]
# eligibility traces of the learners: none (the thesis's algorithms) or lambda = 1
TRACE_DECAY = [0.0, 1.0]
# Algorithm 24's vetoed proposals: learned as a failure (reward -1) or ignored (as printed)
VETO_REWARD = [-1.0, None]
# Each figure's base settings are the ones its grid search selected (chapter5/FIG_selection.csv),
# so `conjure sweep CONFIG --set 'grid={}'` runs the chosen settings.
SELECTIONS = Path(__file__).resolve().parent / "chapter5"
# GridWorld-3 [R] (GridWorld.gridworld_3): wind 0.55 but in the corridor past the danger cell
GRID_3 = {"map_name": "gridworld3", "step_reward": -0.01, "noise": 0.55, "noise_cells": "windy"}
# Section 5.5.3's threshold: from this knownness on the learner's action skips the safety check
# (multiples of 1/K; 0.1 = 1/K: a consulted learner is never checked, the analyser never runs).
# TRUSTED: the base value only; the grid's selection chooses (chapter5/fig_5_14_selection.md).
TRUSTED_KNOWNNESS = [0.1, 0.3, 0.5, 1.0]
TRUSTED = 0.1
# GridWorld-3's seeds, disjoint from every seed the project used before (all below 10,000): the
# selection rule (final return, fixed before any run on them) searches on GRID_3_SEARCH and the
# selected settings are reported on GRID_3_FRESH.
GRID_3_SEARCH = list(range(10000, 10005))
GRID_3_FRESH = list(range(10005, 10065))


def episodic(alpha_0=0.1, n_0=1000):
    """The thesis's step-size schedule (Section 5.3.5)."""
    return {"kind": "EpisodicDecay", "params": {"alpha_0": alpha_0, "n_0": n_0}}


def ch5_sarsa(index):
    """SARSA, epsilon = 0.1, tabular (Sections 5.4.1 and 5.5.2)."""
    return {
        "kind": "SARSA",
        "params": {
            "representation": index,
            "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 0.1}},
            "step_size": episodic(),
        },
    }


def actor_critic(index, critic="q"):
    """Tabular Actor-Critic with a Gibbs actor at tau = 1 (Algorithm 12: critic "q")."""
    return {
        "kind": "ActorCritic",
        "params": {
            "representation": index,
            "policy": {"kind": "Gibbs", "params": {"temperature": 1.0}},
            "step_size": episodic(),
            "critic": critic,
        },
    }


def advantage_actor_critic(index):
    """V critic, log-policy actor with its own step size, eligibility traces (searched)."""
    learner = actor_critic(index, "v")
    learner["params"].update(
        actor_update="log_policy", actor_step_size=episodic(0.001), trace_decay=1.0
    )
    return learner


def model(domain, **params):
    """An ApproximateModel of ``domain`` (a {kind, params} spec)."""
    return {"kind": "ApproximateModel", "params": {"domain": domain, **params}}


def cbba(variant):
    """Aggressive CBBA or conservative CBBA (Algorithm 27) as pi^p."""
    return {"kind": "CBBAPlanner", "params": {"variant": variant}}


def switching(conservative, aggressive):
    """AM-iCCA's planner: conservative until the noise estimate drops below 25%."""
    return {
        "kind": "SwitchingPlanner",
        "params": {"conservative": conservative, "aggressive": aggressive, "noise_threshold": 0.25},
    }


def monte_carlo(risk_tolerance: float = 0.2):
    """Algorithm 25 with M = 5 and risk tolerance ε (Section 5.5.2: 0.2; safe iff risk < ε)."""
    params = {"num_rollouts": 5, "risk_tolerance": risk_tolerance}
    return {"kind": "MonteCarloRiskAnalyzer", "params": params}


def cooperative_actor_critic(learner, planner, risk, approx, index, bias, half_life):
    """An actor-critic inside iCCA (Algorithm 23's control loop)."""
    return {
        "kind": "CooperativeActorCritic",
        "params": {
            "learner": learner,
            "planner": planner,
            "risk": risk,
            "model": approx,
            "index": index,
            "bias": bias,
            "bias_half_life": half_life,
        },
    }


def icca_variants(index, planner, risk, approx):
    """`icca`, `icca_features` and `icca_printed` (see BIAS above)."""
    fading = (BIAS, HALF_LIFE)
    return {
        "icca": cooperative_actor_critic(
            advantage_actor_critic(index), planner, risk, approx, index, *fading
        ),
        "icca_features": cooperative_actor_critic(
            actor_critic(index, "v"), planner, risk, approx, index, *fading
        ),
        "icca_printed": cooperative_actor_critic(
            actor_critic(index), planner, risk, approx, index, 100.0, None
        ),
    }


def advantage_grid(label, path="params"):
    """alpha_0 x N_0 x the actor's alpha_0 x lambda for an advantage actor-critic at ``path``."""
    grid = step_grid([label], f"{path}.step_size")
    grid[f"agents.{label}.{path}.actor_step_size.params.alpha_0"] = ACTOR_ALPHA_0
    grid[f"agents.{label}.{path}.trace_decay"] = TRACE_DECAY
    return grid


def icca_grid():
    """The search of the three iCCA variants (the fading bias is fixed, see BIAS)."""
    grid = advantage_grid("icca", "params.learner.params")
    grid.update(step_grid(["icca_features", "icca_printed"], "params.learner.params.step_size"))
    return grid


def sarsa_grid(labels, path="params", known=(), veto=()):
    """alpha_0 x N_0 x lambda (and K, and the veto rule) for SARSA-based labels at ``path``."""
    grid = step_grid(labels, f"{path}.step_size", known)
    for label in labels:
        grid[f"agents.{label}.{path}.trace_decay"] = TRACE_DECAY
    for label in veto:
        grid[f"agents.{label}.params.veto_reward"] = VETO_REWARD
    return grid


def cooperative(kind, index, planner, risk, approx, **extra):
    """Algorithm 24 (CooperativeLearner, CSARSA) or 26 (AdaptiveCooperativeLearner, AM-iCCA)."""
    return {
        "kind": kind,
        "params": {
            "learner": ch5_sarsa(index),
            "planner": planner,
            "risk": risk,
            "model": approx,
            "index": index,
            "num_known_visits": 10,
            **extra,
        },
    }


def planner_agent(planner, approx):
    """The planner alone (the baselines of Figures 5-5 to 5-13)."""
    return {"kind": "PlannerAgent", "params": {"planner": planner, "model": approx}}


def step_grid(labels, path="params.step_size", known=()):
    """alpha_0 x N_0 for each label (``path`` leads to its schedule); K for ``known`` labels."""
    grid = {}
    for label in labels:
        grid[f"agents.{label}.{path}.params.alpha_0"] = ALPHA_0
        grid[f"agents.{label}.{path}.params.n_0"] = N_0
    for label in known:
        grid[f"agents.{label}.params.num_known_visits"] = KNOWN
    return grid


def setting_value(text):
    """A grid value as `describe_setting` wrote it (Python's ``None`` for YAML's null)."""
    return None if text == "None" else yaml.safe_load(text)


def with_selection(name, agents):
    """``agents`` with the settings FIG's stored grid selection chose as their base values.

    A setting such as ``learner.step_size.alpha_0=1.0`` is the path of parameter names below
    the agent, each inside a component's ``params``.
    """
    path = SELECTIONS / f"{name}_selection.csv"
    if not path.is_file():
        return agents
    with path.open() as handle:
        for row in csv.DictReader(handle):
            if row["label"] not in agents or not row["setting"]:
                continue
            for assignment in row["setting"].split(", "):
                key, value = assignment.split("=", 1)
                node = agents[row["label"]]["params"]
                *parents, last = key.split(".")
                for parent in parents:
                    node = node[parent]["params"]
                node[last] = setting_value(value)
    return agents


def ch5_config(name, domain, agents, grid, budget, eval_episodes, seeds, fresh, criterion="auc"):
    """A chapter-5 sweep: grid selection by ``criterion`` on ``seeds``, then ``fresh``."""
    return {
        "name": name,
        "domain": domain,
        "agents": with_selection(name, agents),
        "grid": grid,
        "budget_steps": budget,
        "num_policy_checks": 10,
        "eval_episodes": eval_episodes,
        "seeds": seeds,
        "metric": "return",
        "selection": {"criterion": criterion, "mode": "max", "fresh_seeds": fresh},
    }


def fig_5_5_and_5_8():
    """GridWorld-1: Actor-Critic vs iCCA (Fig. 5-5) and SARSA vs CSARSA (Fig. 5-8)."""
    world = {"kind": "GridWorld", "params": GRID_1}
    calm = model({"kind": "GridWorld", "params": {**GRID_1, "noise": 0.0}})
    windy = model({"kind": "GridWorld", "params": GRID_1})
    value_iteration = {"kind": "ModelPlanner", "params": {"planner": {"kind": "ValueIteration"}}}
    nominal = {"kind": "NominalRiskAnalyzer"}
    agents = {
        "actor_critic": actor_critic(GRID_INDEX),
        "actor_critic_advantage": advantage_actor_critic(GRID_INDEX),
        **icca_variants(GRID_INDEX, value_iteration, nominal, calm),
        "vi_planner": planner_agent(value_iteration, calm),
        "optimal": planner_agent(value_iteration, windy),
    }
    grid = step_grid(["actor_critic"])
    grid.update(advantage_grid("actor_critic_advantage"))
    grid.update(icca_grid())
    header = (
        "# Geramifard 2012, Fig. 5-5 (Section 5.3.5): GridWorld-1, Actor-Critic (Algorithm 12;\n"
        "# `actor_critic_advantage`: iCCA's learner alone) vs iCCA (V critic, log-policy actor,\n"
        "# eligibility traces, planner bias fading with visits; `icca_features`: Algorithm 12's\n"
        "# actor step, no traces; `icca_printed`: Algorithm 23 as printed, lambda = 100) with\n"
        "# value iteration on the noise-free model and the nominal risk rule, vs the planner\n"
        "# alone vs the optimal policy (value iteration on the true model), 1e4 steps. Step sizes\n"
        "# (and the actor's, and lambda) selected by AUC on seeds 0-4, reported on 60 fresh\n"
        "# seeds; base settings = selected. Generated by docs/reproduction/make_configs.py.\n"
    )
    write("fig_5_5", header, ch5_config("fig_5_5", world, agents, grid, 10000, 100, 5, 60))
    agents = {
        "sarsa": ch5_sarsa(GRID_INDEX),
        "csarsa": cooperative("CooperativeLearner", GRID_INDEX, value_iteration, nominal, calm),
        "csarsa_printed": cooperative(
            "CooperativeLearner", GRID_INDEX, value_iteration, nominal, calm, veto_reward=None
        ),
        "vi_planner": planner_agent(value_iteration, calm),
        "optimal": planner_agent(value_iteration, windy),
    }
    grid = sarsa_grid(["sarsa"])
    learners = ["csarsa", "csarsa_printed"]
    grid.update(sarsa_grid(learners, "params.learner.params", known=learners))
    header = (
        "# Geramifard 2012, Fig. 5-8 (Section 5.4.1): GridWorld-1, SARSA vs CSARSA\n"
        "# (Algorithm 24 with SARSA, value iteration on the noise-free model, nominal risk; a\n"
        "# vetoed proposal learned as a failure, `csarsa_printed`: as printed) vs the planner vs\n"
        "# the optimal policy, 1e4 steps. alpha_0 x N_0 x SARSA's lambda (and K for CSARSA)\n"
        "# selected by AUC on seeds 0-4, reported on 60 fresh seeds; base settings = selected.\n"
        "# Generated by docs/reproduction/make_configs.py.\n"
    )
    write("fig_5_8", header, ch5_config("fig_5_8", world, agents, grid, 10000, 100, 5, 60))


def fig_5_6_and_5_7():
    """Deterministic UAV 7-2 and 10-2: Actor-Critic vs iCCA vs CBBA (Figs. 5-6, 5-7)."""
    # Section 5.3.5: "averaged over 60 runs except for the UAV 10-2 scenario ... 30 runs".
    for figure, scenario, fresh in (("fig_5_6", "uav-7-2", 60), ("fig_5_7", "uav-10-2", 30)):
        world = {"kind": "UAVMission", "params": {"scenario": scenario}}
        approx = model(world)
        fuel = {"kind": "FuelRiskAnalyzer"}
        aggressive = cbba("aggressive")
        agents = {
            "actor_critic": actor_critic(UAV_INDEX),
            "actor_critic_advantage": advantage_actor_critic(UAV_INDEX),
            **icca_variants(UAV_INDEX, aggressive, fuel, approx),
            "cbba": planner_agent(aggressive, approx),
        }
        grid = step_grid(["actor_critic"])
        grid.update(advantage_grid("actor_critic_advantage"))
        grid.update(icca_grid())
        header = (
            f"# Geramifard 2012, Fig. {figure[4:].replace('_', '-')} (Section 5.3.5): {scenario} "
            "without noise, Actor-Critic\n"
            "# (Algorithm 12; `actor_critic_advantage`: iCCA's learner alone) vs iCCA (CBBA with\n"
            "# all fuel, the fuel rule; the learner and variants of fig_5_5.yaml) vs CBBA alone,\n"
            "# 1e5 steps. Step sizes (and the actor's, and lambda) selected by AUC on seeds 0-1,\n"
            f"# reported on {fresh} fresh seeds (the thesis's count); base settings = selected.\n"
            "# Generated by docs/reproduction/make_configs.py.\n"
        )
        config = ch5_config(figure, world, agents, grid, 100000, 100, 2, fresh)
        write(figure, header, config)


def fig_5_9_and_5_13():
    """Noisy UAV 7-2: SARSA, CBBA, CSARSA (Fig. 5-9); iCCA and AM-iCCA (Fig. 5-13)."""
    world = {"kind": "UAVMission", "params": {"scenario": "uav-7-2", "traverse_failure": 0.05}}
    blind = {"kind": "UAVMission", "params": {"scenario": "uav-7-2"}}  # the planner's model
    static = model(blind, initial_noise=0.4)
    adaptive = model(blind, initial_noise=0.4, prior_weight=100.0, is_adaptive=True)
    fuel = {"kind": "FuelRiskAnalyzer"}
    agents = {
        "sarsa": ch5_sarsa(UAV_INDEX),
        "cbba_aggressive": planner_agent(cbba("aggressive"), model(blind)),
        "cbba_conservative": planner_agent(cbba("conservative"), model(blind)),
        "csarsa": cooperative(
            "CooperativeLearner", UAV_INDEX, cbba("aggressive"), fuel, model(blind)
        ),
        "icca": cooperative(
            "CooperativeLearner", UAV_INDEX, cbba("conservative"), monte_carlo(), static
        ),
        "am_icca": cooperative(
            "AdaptiveCooperativeLearner",
            UAV_INDEX,
            switching(cbba("conservative"), cbba("aggressive")),
            monte_carlo(),
            adaptive,
        ),
        "am_icca_tolerant": cooperative(  # one failed rollout in five allowed: risk <= 20%
            "AdaptiveCooperativeLearner",
            UAV_INDEX,
            switching(cbba("conservative"), cbba("aggressive")),
            monte_carlo(risk_tolerance=0.4),
            adaptive,
        ),
        # Algorithm 26 with the fuel rule for Algorithm 25: aggressive CBBA crashes ~21% of the
        # noisy missions, so Algorithm 25's rollouts, which follow it, find most proposals
        # unsafe (Section 5.5.1's condition; docs/reproduction/chapter5/am_icca_switch.md)
        "am_icca_fuel_rule": cooperative(
            "AdaptiveCooperativeLearner",
            UAV_INDEX,
            switching(cbba("conservative"), cbba("aggressive")),
            fuel,
            adaptive,
        ),
    }
    grid = sarsa_grid(["sarsa"])
    learners = ["csarsa", "icca", "am_icca", "am_icca_tolerant", "am_icca_fuel_rule"]
    grid.update(sarsa_grid(learners, "params.learner.params", known=learners, veto=learners))
    for label in learners:  # alpha_0 = 0.01 learns nothing in 1e5 steps
        grid[f"agents.{label}.params.learner.params.step_size.params.alpha_0"] = [0.1, 1.0]
    header = (
        "# Geramifard 2012, Figs. 5-9 (Section 5.4.1) and 5-13 (Section 5.5.2): UAV 7-2 with 5%\n"
        "# edge-traverse failures unknown to the planners. SARSA; aggressive CBBA (the planner of\n"
        "# Fig. 5-9) and conservative CBBA (Algorithm 27); CSARSA (Algorithm 24, aggressive CBBA,\n"
        "# the fuel rule); iCCA (Algorithm 24, conservative CBBA, Monte-Carlo risk at a static\n"
        "# 40% noise); AM-iCCA (Algorithm 26, conservative -> aggressive CBBA below 25%;\n"
        "# `am_icca_tolerant`: a proposal is safe with one failed rollout in five, risk <= 20%;\n"
        "# `am_icca_fuel_rule`: Algorithm 26 with the fuel rule in place of Algorithm 25).\n"
        "# 1e5 steps; alpha_0 x N_0 x SARSA's lambda (and K, and whether a vetoed proposal is\n"
        "# learned as a failure) selected by AUC on seeds 0-1, reported on 60 fresh seeds (the\n"
        "# thesis's count); base settings = selected.\n"
        "# Generated by docs/reproduction/make_configs.py.\n"
    )
    config = ch5_config("fig_5_9_13", world, agents, grid, 100000, 100, 2, 60)
    write("fig_5_9_13", header, config)


def fig_5_12_and_gridworld_3():
    """GridWorld-2: SARSA vs iCCA vs AM-iCCA (Fig. 5-12); GridWorld-3 (Section 5.5.3)."""
    conservative = {"kind": "ShortestPathPlanner", "params": {"goal": [0, 0]}}
    aggressive = {"kind": "ShortestPathPlanner", "params": {"goal": [0, 21]}}
    uniform = {"kind": "GridWorld", "params": GRID_2}
    static = model(uniform, initial_noise=0.4)
    adaptive = model(uniform, initial_noise=0.4, prior_weight=100.0, is_adaptive=True)
    for figure, world, extension in (
        ("fig_5_12", uniform, False),
        ("fig_5_14", {"kind": "GridWorld", "params": GRID_3}, True),
    ):
        agents = {
            "sarsa": ch5_sarsa(GRID_INDEX),
            "icca": cooperative(
                "CooperativeLearner", GRID_INDEX, conservative, monte_carlo(), static
            ),
            "am_icca": cooperative(
                "AdaptiveCooperativeLearner",
                GRID_INDEX,
                switching(conservative, aggressive),
                monte_carlo(),
                adaptive,
            ),
            "conservative": planner_agent(conservative, model(uniform)),
            "aggressive": planner_agent(aggressive, model(uniform)),
        }
        if not extension:  # Algorithm 24 as printed: a vetoed proposal has no consequence
            agents["icca_printed"] = cooperative(
                "CooperativeLearner",
                GRID_INDEX,
                conservative,
                monte_carlo(),
                static,
                veto_reward=None,
            )
        if extension:  # Section 5.5.3: no safety check once a pair is known enough
            del agents["icca"]
            agents["am_icca_switch_off"] = cooperative(
                "AdaptiveCooperativeLearner",
                GRID_INDEX,
                switching(conservative, aggressive),
                monte_carlo(),
                adaptive,
                trusted_knownness=TRUSTED,
            )
        learners = [label for label in agents if label.startswith(("icca", "am_icca"))]
        grid = sarsa_grid(["sarsa"])
        grid.update(sarsa_grid(learners, "params.learner.params"))
        if extension:
            grid["agents.am_icca_switch_off.params.trusted_knownness"] = TRUSTED_KNOWNNESS
        header = (
            "# Geramifard 2012, Fig. 5-12 (Section 5.5.2): GridWorld-2, SARSA vs iCCA\n"
            "# (Algorithm 24, conservative policy, Monte-Carlo risk at a static 40% noise) vs\n"
            "# AM-iCCA (Algorithm 26, conservative -> aggressive policy below 25%) vs the two\n"
            "# static policies; K = 10; a vetoed proposal is learned as a failure (reward -1;\n"
            "# `icca_printed`: as printed). 3e4 steps; alpha_0 x N_0 x SARSA's lambda selected by\n"
            "# AUC on seeds 0-4, reported on 60 fresh seeds; base settings = selected.\n"
            if not extension
            else "# Geramifard 2012, Section 5.5.3 (Fig. 5-14): GridWorld-3 [R]\n"
            "# (GridWorld.gridworld_3: wind 0.55 everywhere but the corridor from beside the\n"
            "# danger cell to the right goal), AM-iCCA with a uniform-noise model, with and\n"
            "# without the safety check switched off from a knownness threshold on\n"
            "# (am_icca_switch_off), vs SARSA and the two static policies. 3e4 steps;\n"
            "# alpha_0 x N_0 x SARSA's lambda (and the threshold) selected by the final return\n"
            "# (the section's claim is where the learners end; rule fixed before any run on\n"
            "# these seeds) on seeds 10000-10004, reported on seeds 10005-10064, disjoint from\n"
            "# every seed used before; base settings = selected.\n"
        ) + "# Generated by docs/reproduction/make_configs.py.\n"
        if extension:
            config = ch5_config(
                figure, world, agents, grid, 30000, 50, GRID_3_SEARCH, GRID_3_FRESH, "final"
            )
        else:
            config = ch5_config(figure, world, agents, grid, 30000, 50, 5, 60)
        write(figure, header, config)


def ifdd_csarsa():
    """Section 6.2.6: CSARSA with online iFDD vs tabular CSARSA on UAV 10-2 (5% noise)."""
    world = {"kind": "UAVMission", "params": {"scenario": "uav-10-2", "traverse_failure": 0.05}}
    blind = model({"kind": "UAVMission", "params": {"scenario": "uav-10-2"}})
    fuel = {"kind": "FuelRiskAnalyzer"}
    ifdd = {
        "kind": "OnlineIFDD",
        "params": {
            "base": {"kind": "IndependentDiscretization", "params": {}},
            "relevance": "ifdd_plus",
            "discovery_threshold": 100.0,
        },
    }
    tabular = cooperative("CooperativeLearner", UAV_INDEX, cbba("aggressive"), fuel, blind)
    with_ifdd = cooperative("CooperativeLearner", UAV_INDEX, cbba("aggressive"), fuel, blind)
    with_ifdd["params"]["learner"]["params"]["representation"] = ifdd
    with_ifdd["params"]["learner"]["params"]["step_size"] = {
        "kind": "FeatureNormalizedDecay",
        "params": {"alpha_0": 1.0, "n_0": 1000},
    }
    agents = {
        "sarsa_ifdd": {**ch5_sarsa(ifdd), "params": {**with_ifdd["params"]["learner"]["params"]}},
        "csarsa_tabular": tabular,
        "csarsa_ifdd": with_ifdd,
        "cbba": planner_agent(cbba("aggressive"), blind),
    }
    grid = {
        "agents.csarsa_tabular.params.learner.params.step_size.params.alpha_0": [0.1, 1.0],
        "agents.csarsa_tabular.params.learner.params.trace_decay": TRACE_DECAY,
        "agents.csarsa_ifdd.params.learner.params.representation.params.discovery_threshold": [
            100.0,
            300.0,
        ],
    }
    for label in ("csarsa_tabular", "csarsa_ifdd"):
        grid[f"agents.{label}.params.veto_reward"] = VETO_REWARD
    header = (
        "# Beyond the thesis (Section 6.2.6): CSARSA (Algorithm 24, aggressive CBBA, fuel rule)\n"
        "# with online iFDD+ as the learner's representation vs tabular CSARSA and SARSA + iFDD+\n"
        "# on UAV 10-2 with 5% traverse failures, 1e5 steps. Step size / threshold selected by\n"
        "# AUC on seeds 0-1 (with SARSA's lambda for the tabular learner and the veto rule for\n"
        "# both), reported on 30 fresh seeds; base settings = selected.\n"
        "# Generated by docs/reproduction/make_configs.py.\n"
    )
    write("ifdd_csarsa", header, ch5_config("ifdd_csarsa", world, agents, grid, 100000, 100, 2, 30))


# The safe-RL comparison (beyond the thesis): per domain, the cost limit d on the expected
# failures per episode, between the optimal policy's and the planner's (GridWorld-1: optimal
# 0.096, value iteration on the calm model 0.363; GridWorld-2: SARSA 0.002, the aggressive
# policy 0.060; UAV 7-2 at 5%: conservative CBBA 0.000, aggressive CBBA 0.213; the stored
# chapter5/*_finals.csv), the source figures whose selected settings the learners reuse, the
# budget and the evaluation episodes. Seeds 40000-40004 search, 40005-40034 report: disjoint
# from every seed the project used before (all below 10,065).
SAFE_RL = {
    "safe_rl_gridworld_1": (0.15, 10000, 100),
    "safe_rl_gridworld_2": (0.05, 30000, 50),
    "safe_rl_uav_7_2": (0.1, 100000, 100),
}
SAFE_SEARCH = list(range(40000, 40005))
SAFE_FRESH = list(range(40005, 40035))
MULTIPLIER_STEP = [0.01, 0.1, 1.0]
PID_KP = [0.1, 1.0, 10.0]
PID_KI = [0.01, 0.1, 1.0]


def shipped(name):
    """The agents of a shipped chapter-5 config (base settings = its selection), copied."""
    config = yaml.safe_load((OUT / f"{name}.yaml").read_text())
    return copy.deepcopy(config["domain"]), copy.deepcopy(config["agents"])


def constrained(learner, rule, cost_limit):
    """``learner`` (an agent spec) with a cost constraint of ``rule`` at limit ``cost_limit``."""
    spec = copy.deepcopy(learner)
    params = {"cost_limit": cost_limit}
    if rule == "PIDLagrangian":
        params.update(kp=1.0, ki=0.1)
    spec["params"]["constraint"] = {"kind": rule, "params": params}
    return spec


def shield(learner, box):
    """A `ShieldedLearner`: ``learner`` behind the risk analyser and model of ``box``."""
    params = {key: copy.deepcopy(box["params"][key]) for key in ("planner", "risk", "model")}
    return {"kind": "ShieldedLearner", "params": {"learner": copy.deepcopy(learner), **params}}


def constraint_grid(labels):
    """η for the Lagrangian learners, K_p x K_i for the PID ones.

    The learners' own step sizes are the source figure's selection, not searched again.
    """
    grid = {}
    for label in labels:
        key = f"agents.{label}.params.constraint.params"
        if "_pid_" not in label:
            grid[f"{key}.multiplier_step_size"] = MULTIPLIER_STEP
        else:
            grid[f"{key}.kp"], grid[f"{key}.ki"] = PID_KP, PID_KI
    return grid


def safe_rl():
    """Safe exploration against constrained RL on the same features and seeds (issue 34)."""
    world, gw1_sarsa = shipped("fig_5_8")
    _, gw1_ac = shipped("fig_5_5")
    _, gw2 = shipped("fig_5_12")
    uav_world, uav = shipped("fig_5_9_13")
    _, uav_ac = shipped("fig_5_6")
    sources = {
        "safe_rl_gridworld_1": (
            world,
            {
                "sarsa": gw1_sarsa["sarsa"],
                "actor_critic_advantage": gw1_ac["actor_critic_advantage"],
                "csarsa": gw1_sarsa["csarsa"],
                "icca": gw1_ac["icca"],
            },
            ("csarsa", "actor_critic_advantage"),
        ),
        "safe_rl_gridworld_2": (
            shipped("fig_5_12")[0],
            {key: gw2[key] for key in ("sarsa", "icca", "am_icca")},
            ("icca", None),
        ),
        "safe_rl_uav_7_2": (
            uav_world,
            {
                "sarsa": uav["sarsa"],
                "actor_critic": uav_ac["actor_critic"],
                **{key: uav[key] for key in ("csarsa", "icca", "am_icca")},
            },
            ("csarsa", "actor_critic"),
        ),
    }
    for name, (domain, agents, (box, actor)) in sources.items():
        cost_limit, budget, eval_episodes = SAFE_RL[name]
        learners = {
            "sarsa_lagrangian": constrained(agents["sarsa"], "Lagrangian", cost_limit),
            "sarsa_pid_lagrangian": constrained(agents["sarsa"], "PIDLagrangian", cost_limit),
        }
        if actor is not None:
            learners["actor_critic_pid_lagrangian"] = constrained(
                agents[actor], "PIDLagrangian", cost_limit
            )
        agents = {**agents, **learners}
        # The shield runs on the Python path and judges every action each step: with the
        # Monte-Carlo analyser (GridWorld-2's box) a run took about 6 minutes on 2 loaded
        # cores, so it is left out there.
        if agents[box]["params"]["risk"]["kind"] != "MonteCarloRiskAnalyzer":
            agents["shield"] = shield(agents["sarsa"], agents[box])
        header = (
            f"# Beyond the thesis: safe exploration (iCCA, Chapter 5) against constrained RL on\n"
            f"# the same features, budgets and seeds, a cost limit d = {cost_limit} failures per\n"
            f"# episode. The learners alone, CSARSA, iCCA and AM-iCCA keep the settings their\n"
            f"# source figure selected (fig_5_5/5_8, fig_5_12, fig_5_6/5_9_13); the constrained\n"
            f"# learners (Lagrangian, PID-Lagrangian: conjure.agents.constraints) are those\n"
            f"# learners with a constraint, eta or K_p x K_i searched; the shield is SARSA behind\n"
            f"# the box's risk analyser and model (ShieldedLearner). Selection rule, fixed before\n"
            f"# any run: the best AUC of return among the settings whose mean final episodic\n"
            f"# cost is within d, on seeds 40000-40004; reported on seeds 40005-40034.\n"
            f"# Generated by docs/reproduction/make_configs.py.\n"
        )
        config = ch5_config(
            name, domain, agents, constraint_grid(learners), budget, eval_episodes,
            SAFE_SEARCH, SAFE_FRESH,
        )  # fmt: skip
        config["selection"]["cost_limit"] = cost_limit
        write(name, header, config)
        if name == "safe_rl_gridworld_1":  # the same methods with ten times the experience
            long = {**config, "name": f"{name}_1e5", "grid": {}, "budget_steps": 100000}
            long["seeds"] = SAFE_FRESH
            del long["selection"]
            header = (
                "# The safe-RL comparison on GridWorld-1 (safe_rl_gridworld_1.yaml) with 1e5\n"
                "# learning steps instead of 1e4: the settings selected there, no search,\n"
                "# reported on its report seeds 40005-40034.\n"
                "# Generated by docs/reproduction/make_configs.py.\n"
            )
            write(f"{name}_1e5", header, long)


if __name__ == "__main__":
    if "--out" in sys.argv[1:]:
        OUT = Path(sys.argv[sys.argv.index("--out") + 1])
    OUT.mkdir(parents=True, exist_ok=True)
    fig_4_5()
    fig_4_7()
    fig_4_11()
    investigations()
    fig_4_8_pendulum_ifdd_plus()
    fig_5_5_and_5_8()
    fig_5_6_and_5_7()
    fig_5_9_and_5_13()
    fig_5_12_and_gridworld_3()
    ifdd_csarsa()
    safe_rl()
