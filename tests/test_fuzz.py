"""Property-based fuzzing (hypothesis): bad input gets one clear line, never a traceback or a hang.

Mutations of the shipped configs (as text and as a tree), of component parameters and of
saved agents must each end in a finished load / build / restore / run, or in a `ConjureError`
of one line (exit status 2 on the command line). Every case runs under a wall-clock bound
(`FUZZ_CASE_SECONDS`); a case past it is a hang and fails the test.

The CI size is a few hundred cases, the same ones every time (derandomized); the long mode
draws from ``--hypothesis-seed``. ``--fuzz N`` (or ``CONJURE_FUZZ=N``) runs N in-process
cases in all (15% configs, 45% component parameters, 40% saves) and N // 40 end-to-end
``conjure run`` cases, for release checks::

    python -m pytest -n 0 -q -s tests/test_fuzz.py --fuzz 10000
"""

from __future__ import annotations

import copy
import json
import math
import os
import signal
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from conjure.agents import SARSA
from conjure.cli.main import main
from conjure.core.errors import ConjureError
from conjure.domains import ChainMDP
from conjure.experiments import registry
from conjure.experiments.config import load_config
from conjure.policies import EpsilonGreedy
from conjure.representations import Tabular, TileCoding
from conjure.sweeps.sweep import load_sweep
from conjure.sweeps.tune import load_tune

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted(p for p in (ROOT / "examples").rglob("*.yaml") if not p.name.startswith("solve"))
#: The wall-clock bound of one in-process case (a config, a component, a restore).
FUZZ_CASE_SECONDS = 30
#: The wall-clock bound of one end-to-end ``conjure run`` case.
RUN_CASE_SECONDS = 120

#: Values that break types, ranges and sizes: what a typo or a hostile file puts in a field.
ODD_VALUES = [
    None,
    True,
    0,
    -1,
    1,
    2,
    3,
    7,
    2**31 - 1,
    2**63 - 1,
    2**63,
    10**20,
    -(10**20),
    0.0,
    -0.0,
    0.5,
    -0.5,
    1.5,
    1e-300,
    1e15,
    1e300,
    math.inf,
    -math.inf,
    math.nan,
    "",
    "x",
    "1e-3",
    "0..5",
    "5..0",
    "4GiB",
    "64MiB",
    "ChainMDP",
    [],
    [1, 2],
    [[[[[]]]]],
    {},
    {"kind": "Tabular"},
    {"kind": "Nope", "params": {}},
]


def _settings(request: pytest.FixtureRequest, max_examples: int) -> Any:
    """Hypothesis settings of a fuzz property: no deadline (the alarm bounds a case), no example
    database, and no explain phase (its line tracing slows a case tenfold)."""
    return settings(
        max_examples=max_examples,
        deadline=None,
        derandomize=not request.config.getoption("--fuzz"),
        suppress_health_check=list(HealthCheck),
        database=None,
        phases=[Phase.explicit, Phase.reuse, Phase.generate, Phase.shrink],
    )


def _cases(ci: int, config: pytest.Config, share: float) -> int:
    """``ci`` cases, or this property's ``share`` of the ``--fuzz`` total."""
    total = config.getoption("--fuzz")
    return max(round(total * share), 1) if total else ci


#: Outcomes per property, printed at the end of each test (``-s`` shows them).
OUTCOMES: dict[str, dict[str, int]] = {}


def _count(test: str, outcome: str) -> None:
    counts = OUTCOMES.setdefault(test, {})
    counts[outcome] = counts.get(outcome, 0) + 1
    log = os.environ.get("CONJURE_FUZZ_LOG")  # the counts so far, for a long run watched live
    if log:
        Path(log).write_text(json.dumps(OUTCOMES))


def _print_outcomes(test: str) -> None:
    print(f"\n{test}: {OUTCOMES.get(test, {})}")


@contextmanager
def bounded(seconds: int) -> Iterator[None]:
    """Fail the case if it runs longer than ``seconds`` (SIGALRM; the compiled loop's calls are
    time-sized, so the alarm lands between them)."""

    def hang(signum: int, frame: Any) -> None:
        raise _Hang(f"a case ran past {seconds} s")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


class _Hang(BaseException):
    """Raised by the alarm: a BaseException, so no `except Exception` in conjure swallows it."""


def _subclasses(cls: type) -> set[str]:
    return {cls.__name__}.union(*(_subclasses(sub) for sub in cls.__subclasses__()))


#: The names of conjure's error classes: a failed run's recorded error must be one of them.
CONJURE_ERRORS = _subclasses(ConjureError)


def assert_one_line(exc: BaseException) -> None:
    assert isinstance(exc, ConjureError), f"{type(exc).__name__} escaped: {exc!r}"[:2000]
    text = str(exc)
    assert text.strip() and "Traceback" not in text, text[:2000]


def _load_any(path: Path) -> Any:
    """Load a config with the loader its error names: experiment, sweep or tuning."""
    try:
        return load_config(path)
    except ConjureError as exc:
        if "is a sweep config" in str(exc):
            return load_sweep(path)
        if "is a tuning config" in str(exc):
            return load_tune(path)
        raise


# ---------------------------------------------------------------------------------------------
# Mutations


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path into a YAML tree (mapping keys and list indices), the root included."""
    found = [prefix]
    if isinstance(node, dict):
        for key, value in node.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            found += _paths(value, (*prefix, index))
    return found


def _mutate_tree(tree: Any, data: st.DataObject) -> Any:
    tree = copy.deepcopy(tree)
    paths = _paths(tree)
    path = data.draw(st.sampled_from(paths[1:] or paths), label="path")
    parent = tree
    for key in path[:-1]:
        parent = parent[key]
    action = data.draw(st.sampled_from(["replace", "replace", "replace", "delete", "add"]))
    value = data.draw(st.sampled_from(ODD_VALUES) | st.integers() | st.floats(), label="value")
    if action == "delete" and isinstance(parent, dict):
        del parent[path[-1]]
    elif action == "add" and isinstance(parent, dict):
        parent[data.draw(st.sampled_from(["extra", "params", "kind", "seeds"]))] = value
    else:
        parent[path[-1]] = value
    return tree


def _mutate_bytes(raw: bytes, data: st.DataObject) -> bytes:
    action = data.draw(st.sampled_from(["flip", "insert", "cut", "nest", "long int"]))
    at = data.draw(st.integers(0, max(len(raw) - 1, 0)), label="at")
    if action == "flip" and raw:
        return raw[:at] + bytes([raw[at] ^ data.draw(st.integers(1, 255))]) + raw[at + 1 :]
    if action == "insert":
        return raw[:at] + data.draw(st.binary(min_size=1, max_size=8)) + raw[at:]
    if action == "cut":
        return raw[:at]
    if action == "nest":
        depth = data.draw(st.integers(50, 5000))
        return raw + b"\nextra: " + b"[" * depth + b"]" * depth + b"\n"
    return raw + b"\neval_episodes: " + b"9" * data.draw(st.integers(20, 6000)) + b"\n"


# ---------------------------------------------------------------------------------------------
# In-process properties


@pytest.fixture(scope="module")
def shipped_trees() -> list[tuple[Path, Any]]:
    return [(path, yaml.safe_load(path.read_text())) for path in SHIPPED]


def test_fuzzed_config_files_load_or_fail_in_one_line(request, tmp_path_factory, shipped_trees):
    folder = tmp_path_factory.mktemp("configs")

    @_settings(request, _cases(40, request.config, 0.15))
    @given(data=st.data())
    def check(data: st.DataObject) -> None:
        index = data.draw(st.integers(0, len(shipped_trees) - 1), label="config")
        source, tree = shipped_trees[index]
        path = folder / source.name
        if data.draw(st.booleans(), label="as text"):
            path.write_bytes(_mutate_bytes(source.read_bytes(), data))
        else:
            path.write_text(yaml.safe_dump(_mutate_tree(tree, data), sort_keys=False))
        with bounded(FUZZ_CASE_SECONDS):
            try:
                _load_any(path)
            except Exception as exc:
                assert_one_line(exc)
                _count("configs", "clear error")
            else:
                _count("configs", "finished")

    check()
    _print_outcomes("configs")


def _component_specs(tree: Any) -> Iterator[dict[str, Any]]:
    if isinstance(tree, dict):
        if "kind" in tree and set(tree) <= {"kind", "params"} and isinstance(tree["kind"], str):
            yield tree
        for value in tree.values():
            yield from _component_specs(value)
    elif isinstance(tree, list):
        for value in tree:
            yield from _component_specs(value)


@pytest.fixture(scope="module")
def component_specs(shipped_trees) -> list[dict[str, Any]]:
    specs = {
        json.dumps(s, sort_keys=True, default=str)
        for _, t in shipped_trees
        for s in _component_specs(t)
    }
    kinds = {json.dumps({"kind": k}) for layer in registry.LAYERS.values() for k in layer}
    return [json.loads(s) for s in sorted(specs | kinds)]


def test_fuzzed_component_parameters_validate_or_fail_in_one_line(request, component_specs):
    @_settings(request, _cases(150, request.config, 0.45))
    @given(data=st.data())
    def check(data: st.DataObject) -> None:
        spec = copy.deepcopy(data.draw(st.sampled_from(component_specs), label="spec"))
        cls = registry.find_kind(spec["kind"])
        names = cls.param_names()
        params = spec.setdefault("params", {}) or {}
        spec["params"] = params
        for _ in range(data.draw(st.integers(1, 3), label="changes")):
            name = data.draw(st.sampled_from([*names, "not_a_parameter"]), label="name")
            value = data.draw(st.sampled_from(ODD_VALUES) | st.integers() | st.floats())
            params[name] = value
        with bounded(FUZZ_CASE_SECONDS):
            try:
                registry.build(None, spec)
            except Exception as exc:
                assert_one_line(exc)
                _count("components", "clear error")
            else:
                _count("components", "finished")

    check()
    _print_outcomes("components")


@pytest.fixture(scope="module")
def saved_agents(tmp_path_factory) -> list[Path]:
    folder = tmp_path_factory.mktemp("saves")
    spec = ChainMDP(num_states=5).domain_spec
    agents = [
        SARSA(representation=Tabular(), policy=EpsilonGreedy(epsilon=0.2)),
        SARSA(representation=TileCoding(num_tilings=2, tiles_per_dim=3), trace_decay=0.5),
    ]
    return [agent.setup(spec, seed=0).save(folder / f"agent{i}") for i, agent in enumerate(agents)]


def _mutate_save(directory: Path, data: st.DataObject) -> None:
    target = data.draw(st.sampled_from(["json tree", "json bytes", "npz bytes", "npz member"]))
    metadata, arrays = directory / "agent.json", directory / "arrays.npz"
    if target == "json tree":
        document = _mutate_tree(json.loads(metadata.read_text()), data)
        metadata.write_text(json.dumps(document, default=str))
    elif target == "json bytes":
        metadata.write_bytes(_mutate_bytes(metadata.read_bytes(), data))
    elif target == "npz bytes":
        arrays.write_bytes(_mutate_bytes(arrays.read_bytes(), data))
    else:
        with zipfile.ZipFile(arrays) as archive:
            members = {name: archive.read(name) for name in archive.namelist()}
        name = data.draw(st.sampled_from(sorted(members)), label="member")
        members[name] = _mutate_bytes(members[name], data)
        with zipfile.ZipFile(arrays, "w") as archive:
            for member, payload in members.items():
                archive.writestr(member, payload)


def test_fuzzed_saves_restore_or_fail_in_one_line(request, tmp_path_factory, saved_agents):
    folder = tmp_path_factory.mktemp("mutated")

    @_settings(request, _cases(100, request.config, 0.40))
    @given(data=st.data())
    def check(data: st.DataObject) -> None:
        source = saved_agents[data.draw(st.integers(0, len(saved_agents) - 1), label="save")]
        directory = folder / "agent"
        directory.mkdir(exist_ok=True)
        for name in ("agent.json", "arrays.npz"):
            (directory / name).write_bytes((source / name).read_bytes())
        _mutate_save(directory, data)
        with bounded(FUZZ_CASE_SECONDS):
            try:
                SARSA.restore(directory)
            except Exception as exc:
                assert_one_line(exc)
                _count("saves", "clear error")
            else:
                _count("saves", "finished")

    check()
    _print_outcomes("saves")


# ---------------------------------------------------------------------------------------------
# End to end: `conjure run` on mutated small configs


SMALL = {
    "name": "fuzz",
    "domain": {"kind": "ChainMDP", "params": {"num_states": 5, "num_actions": 2}},
    "agents": {
        "q": {"kind": "QLearning", "params": {"representation": {"kind": "Tabular"}}},
        "sarsa": {
            "kind": "SARSA",
            "params": {
                "representation": {"kind": "TileCoding", "params": {"num_tilings": 2}},
                "policy": {"kind": "EpsilonGreedy", "params": {"epsilon": 0.1}},
                "step_size": {"kind": "EpisodicDecay", "params": {"alpha_0": 0.1, "n_0": 100}},
            },
        },
    },
    "budget_steps": 300,
    "num_policy_checks": 3,
    "seeds": 1,
}


@pytest.mark.slow
def test_fuzzed_conjure_run_finishes_or_fails_in_one_line(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    total = request.config.getoption("--fuzz")

    @_settings(request, max(total // 40, 1) if total else 4)
    @given(data=st.data())
    def check(data: st.DataObject) -> None:
        tree = _mutate_tree(SMALL, data)
        path = folder / "fuzz.yaml"
        path.write_text(yaml.safe_dump(tree, sort_keys=False))
        out = folder / f"out{sum(OUTCOMES.get('conjure run', {}).values())}"
        with bounded(RUN_CASE_SECONDS):
            result = CliRunner().invoke(
                main, ["run", str(path), "--out", str(out), "--quiet", "--max-workers", "1"]
            )
        if isinstance(result.exception, _Hang):
            raise AssertionError(f"conjure run hung on {tree}")
        if not isinstance(result.exception, (SystemExit, type(None))):
            raise AssertionError(f"traceback on {tree}: {result.exc_info}")
        assert "Traceback" not in result.output, result.output
        if result.exit_code == 2:
            assert len(result.output.strip().splitlines()) == 1, result.output
            _count("conjure run", "clear error")
            return
        failures = sorted((out / "errors").glob("*.txt"))
        for failure in failures:  # a failed run must fail with a conjure error, not a bug
            last = failure.read_text().strip().splitlines()[-1]
            assert last.split(":")[0].rsplit(".", 1)[-1] in CONJURE_ERRORS, (tree, last)
        assert result.exit_code == (1 if failures else 0), result.output
        _count("conjure run", "run failed with a conjure error" if failures else "finished")

    check()
    _print_outcomes("conjure run")
