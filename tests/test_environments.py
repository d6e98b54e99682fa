"""`import conjure` registers every conjure environment with Gymnasium, and stays light.

Each check runs in a fresh interpreter: the test process has imported everything already.
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym

import conjure.domains
from conjure.environments import ENVIRONMENTS, register_environments
from fresh_python import python


def test_import_conjure_alone_makes_gymnasium_environments():
    result = python("import conjure, gymnasium; gymnasium.make('conjure/GridWorld1-v0')")
    assert result.returncode == 0, result.stderr


def test_import_conjure_loads_no_domain_code_and_registers_the_whole_table():
    result = python(
        "import json, sys, conjure, gymnasium\n"
        "ids = sorted(i for i in gymnasium.registry if i.startswith('conjure/'))\n"
        "heavy = sorted(m for m in sys.modules if m.startswith('conjure.domains')"
        " or m.split('.')[0] in ('pandas', 'matplotlib', 'numba', 'scipy'))\n"
        "print(json.dumps([ids, heavy]))"
    )
    assert result.returncode == 0, result.stderr
    ids, heavy = json.loads(result.stdout)
    assert ids == sorted(entry[0] for entry in ENVIRONMENTS)
    assert heavy == []


def test_every_registered_environment_can_be_made_and_reset():
    result = python(
        "import conjure, gymnasium\n"
        "from conjure.environments import ENVIRONMENTS\n"
        "for env_id, *_ in ENVIRONMENTS:\n"
        "    env = gymnasium.make(env_id)\n"
        "    observation, info = env.reset(seed=0)\n"
        "    assert env.observation_space.contains(observation), env_id\n"
        "    assert env.spec.max_episode_steps > 0, env_id\n"
        "    env.close()\n"
    )
    assert result.returncode == 0, result.stderr


def test_importing_the_domains_again_registers_nothing_twice():
    # Gymnasium warns when an id is registered twice; -W error turns that into a failure.
    result = python(
        "import conjure.domains, gymnasium\n"
        "from conjure.environments import register_environments\n"
        "register_environments()\n"
        "gymnasium.make('conjure/InvertedPendulum-v0')"
    )
    assert result.returncode == 0, result.stderr


def test_the_table_lists_each_id_once_and_covers_every_shipped_domain():
    ids = [entry[0] for entry in ENVIRONMENTS]
    assert len(set(ids)) == len(ids)
    assert all(env_id.startswith("conjure/") for env_id in ids)
    classes = {entry[1].rsplit(":", 1)[1] for entry in ENVIRONMENTS}
    shipped = {
        name
        for name in conjure.domains.__all__
        if isinstance(getattr(conjure.domains, name), type)
        and issubclass(getattr(conjure.domains, name), gym.Env)
        and name != "GymnasiumDomain"  # wraps another environment: nothing to register
    }
    assert shipped <= classes, f"domains without an environment id: {shipped - classes}"


def test_registration_is_idempotent_in_this_process():
    before = {i: gym.registry[i] for i in gym.registry if i.startswith("conjure/")}
    register_environments()
    after = {i: gym.registry[i] for i in gym.registry if i.startswith("conjure/")}
    assert after == before and len(after) == len(ENVIRONMENTS)


def test_import_conjure_loads_no_pandas_matplotlib_or_scipy_stats():
    out = python(
        "import conjure, sys; "
        "print(sorted(m for m in ('pandas', 'matplotlib', 'scipy.stats') if m in sys.modules))"
    )
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


def environment_table() -> str:
    """The markdown table of every id, generated from `ENVIRONMENTS` (docs/other-libraries.md)."""
    lines = ["| id | domain | keyword arguments | episode cap |", "|---|---|---|---|"]
    for env_id, entry_point, max_episode_steps, kwargs in ENVIRONMENTS:
        arguments = ", ".join(f"{name}={value!r}" for name, value in kwargs.items())
        shown = f"`{arguments}`" if arguments else "(defaults)"
        domain = entry_point.rsplit(":", 1)[1]
        lines.append(f"| `{env_id}` | `{domain}` | {shown} | {max_episode_steps:,} |")
    return "\n".join(lines) + "\n"


def test_the_docs_list_every_environment_id_in_one_generated_table():
    doc = (Path(__file__).resolve().parents[1] / "docs" / "other-libraries.md").read_text()
    assert environment_table() in doc, "regenerate the table with tests/test_environments.py"
    assert "conjure.environments`" not in doc  # the module holds ENVIRONMENTS, not a list
