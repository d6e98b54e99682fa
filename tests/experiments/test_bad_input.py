"""Each bad input a fuzzing pass found answers with one line (exit 2), never a traceback."""

from __future__ import annotations

import json
import math
import textwrap
import zipfile

import numpy as np
import pandas as pd
import pytest
import yaml
from click.testing import CliRunner

from conjure.agents import SARSA, persistence
from conjure.cli.main import main
from conjure.core.errors import InvalidParameterError
from conjure.domains import ChainMDP, GridWorld, InvertedPendulum, PersistentSurveillance
from conjure.experiments.config import load_config, parse_config
from conjure.experiments.limits import MAX_SEED_COUNT, parse_seeds
from conjure.experiments.memory import parse_memory_limit
from conjure.experiments.parallel import run_experiment
from conjure.experiments.results import load_results, read_run, run_path
from conjure.experiments.run import TIMING_COLUMNS, run
from conjure.models.approximate_model import ApproximateModel
from conjure.planners import FittedValueIteration
from conjure.reporting.report import _selection_table
from conjure.representations import OnlineIFDD, Tabular
from conjure.sweeps.sweep import load_sweep

TINY = textwrap.dedent(
    """\
    name: tiny
    domain: {kind: ChainMDP, params: {num_states: 4, num_actions: 2}}
    agents:
      q:
        kind: QLearning
        params: {representation: {kind: Tabular}, step_size: 0.5}
    budget_steps: 40
    num_policy_checks: 2
    seeds: 2
    """
)


def _write(tmp_path, data: bytes | str):
    path = tmp_path / "bad.yaml"
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


def _with(line: str) -> str:
    """TINY with ``line`` (``key: value``) in place of its own line for that key, if any."""
    key = line.split(":")[0]
    kept = [old for old in TINY.splitlines() if not old.startswith(f"{key}:")]
    return "\n".join([*kept, line]) + "\n"


def _one_line_error(tmp_path, data, match):
    path = _write(tmp_path, data)
    with pytest.raises(InvalidParameterError, match=match) as info:
        load_config(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    return info.value


def test_a_non_utf8_or_binary_config_is_one_line_with_exit_2(tmp_path):
    _one_line_error(tmp_path, b"name: x\n\xff\n", "not a UTF-8 text file .byte 0xff")
    _one_line_error(tmp_path, bytes(range(256)) * 4, "not a UTF-8 text file")
    result = CliRunner().invoke(main, ["run", str(tmp_path / "bad.yaml")])
    assert result.exit_code == 2 and "not a UTF-8 text file" in result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1


def test_deep_nesting_long_integers_and_repeated_keys_are_refused(tmp_path):
    _one_line_error(tmp_path, "x: " + "[" * 3000 + "]" * 3000, "nested deeper than 100")
    _one_line_error(tmp_path, _with("eval_episodes: " + "9" * 5000), "integer literal of 5,000")
    _one_line_error(tmp_path, TINY + "budget_steps: 50\n", "key 'budget_steps' is given twice")


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("seeds: 1e30", "seeds: seeds must be a count"),
        ("seeds: 9223372036854775808", "seed count must be an int in"),
        ("seeds: [9223372036854775808]", "seeds must be a count"),
        ("num_policy_checks: 1000000000000000000000000000000", "num_policy_checks"),
        ("num_policy_checks: 41", "must be at most `budget_steps` .40."),
        ("budget_steps: 100000000000000000000", "budget_steps"),
        ("eval_episodes: 10000000000", "eval_episodes"),
        ("max_memory: 64MiB", "at least 1 GiB"),
    ],
)
def test_counts_past_what_a_run_can_do_are_refused(tmp_path, line, match):
    _one_line_error(tmp_path, _with(line), match)


@pytest.mark.parametrize(
    "schedule",
    [
        "{kind: ConstantStepSize, params: {alpha_0: .inf}}",
        "{kind: EpisodicDecay, params: {alpha_0: 0.1, n_0: .inf}}",
        "{kind: FeatureNormalizedDecay, params: {alpha_0: 1e15}}",
    ],
)
def test_step_sizes_that_can_only_diverge_are_refused_before_any_run(tmp_path, schedule):
    text = TINY.replace("step_size: 0.5", f"step_size: {schedule}")
    _one_line_error(tmp_path, text, r"alpha_0|n_0")


def test_a_seed_range_is_inclusive_and_a_bad_one_is_one_line(tmp_path):
    path = _write(tmp_path, TINY)
    assert load_config(path, ["seeds=100..129"]).seed_list() == list(range(100, 130))
    assert load_config(_write(tmp_path, TINY.replace("seeds: 2", "seeds: 3..4"))).seed_list() == [
        3,
        4,
    ]
    _write(tmp_path, TINY)
    for bad in ("5..3", "-1..4", "a..b", f"0..{MAX_SEED_COUNT}"):
        with pytest.raises(InvalidParameterError, match="seed"):
            load_config(path, [f"seeds={bad}"])
    assert parse_seeds("7..7") == [7]


def test_max_memory_below_the_floor_is_one_line_naming_value_and_unit():
    with pytest.raises(InvalidParameterError, match=r"got '100MiB' = 100 MiB"):
        parse_memory_limit("100MiB")
    assert parse_memory_limit("1GiB") == 2**30


@pytest.mark.parametrize(
    "component",
    [
        lambda: InvertedPendulum(force_noise=math.inf),
        lambda: ApproximateModel(domain=GridWorld(), prior_weight=math.inf),
        lambda: OnlineIFDD(base=Tabular(), discovery_rate=math.inf),
        lambda: PersistentSurveillance(max_episode_steps=10**20),
        lambda: FittedValueIteration(num_next_samples=10**20),
    ],
)
def test_open_ranges_exclude_inf_and_counts_have_sense_bounds(component):
    with pytest.raises(InvalidParameterError, match=r"must be .* in [\[(]"):
        component().validate_params()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"budget_steps": 10**20}, r"`run.budget_steps` must be an int in \[1, "),
        ({"num_policy_checks": 10**7}, "run.num_policy_checks"),
        ({"compile_steps": "x"}, "`run.compile_steps` must be an int"),
        ({"compile_steps": -1}, "`run.compile_steps` must be an int"),
    ],
)
def test_run_refuses_counts_it_cannot_do(kwargs, match):
    arguments = {"budget_steps": 10, "num_policy_checks": 2, **kwargs}
    domain, agent = ChainMDP(), SARSA(representation=Tabular())
    with pytest.raises(InvalidParameterError, match=match):
        run(domain=domain, agent=agent, seed=0, **arguments)


def _saved_agent(tmp_path):
    agent = SARSA(representation=Tabular()).setup(ChainMDP(num_states=4).domain_spec, seed=0)
    return agent.save(tmp_path / "agent")


def _forge_header(npy: bytes, shape: tuple[int, ...]) -> bytes:
    """The same .npy bytes with a header of the same length declaring ``shape``."""
    length = int.from_bytes(npy[8:10], "little")
    header = npy[10 : 10 + length].decode("latin1")
    start = header.index("'shape': (")
    old = header[start : header.index(")", start) + 1]
    forged = header.replace(old, f"'shape': {shape}").rstrip().ljust(length - 1) + "\n"
    assert len(forged) == length
    return npy[:10] + forged.encode("latin1") + npy[10 + length :]


def test_a_forged_npy_header_is_refused_before_reading(tmp_path):
    directory = _saved_agent(tmp_path)
    npz = directory / "arrays.npz"
    with zipfile.ZipFile(npz) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    members["weights.npy"] = _forge_header(members["weights.npy"], (10**12,))
    with zipfile.ZipFile(npz, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    with pytest.raises(InvalidParameterError, match=r"npz.*declares shape \(10{12},\)"):
        SARSA.restore(directory)


def test_a_member_the_agent_does_not_need_is_never_read(tmp_path):
    directory = _saved_agent(tmp_path)
    weights = SARSA.restore(directory).weights_
    npz = directory / "arrays.npz"
    with zipfile.ZipFile(npz, "a", compression=zipfile.ZIP_DEFLATED) as archive:
        buffer = np.lib.format.header_data_from_array_1_0(np.zeros(2**20))
        with archive.open("unused.npy", "w") as member:
            np.lib.format.write_array_header_1_0(member, buffer)
            member.write(bytes(8 * 2**20))
    assert SARSA.restore(directory).weights_.shape == weights.shape
    saved = persistence.read(directory)
    assert "unused" in saved.arrays and "unused" not in saved.arrays._cache


def test_deeply_nested_agent_json_is_one_error_naming_the_file(tmp_path):
    directory = _saved_agent(tmp_path)
    (directory / "agent.json").write_text("[" * 100_000)
    with pytest.raises(InvalidParameterError, match=r"agent.json.*nested too deeply"):
        SARSA.restore(directory)


def test_report_works_with_one_seed():
    selection = pd.DataFrame(
        {"setting": [""], "score_mean": ["4.0"], "criterion": ["auc"], "score_ci95": [""]}
    )
    assert _selection_table(selection, pd.DataFrame(), "return")["score ± 95% t"][0] == "4.000"


def test_an_edited_run_file_is_redone_and_a_quiet_resume_says_so(tmp_path, capsys):
    config = parse_config(yaml.safe_load(TINY))
    first = run_experiment(config, tmp_path, max_workers=1, progress=False)
    path = run_path(tmp_path, first.results["run_id"].iloc[0])
    original = read_run(path)["curve"]
    record = json.loads(path.read_text())
    record["curve"]["return"] = [value + 1000 for value in record["curve"]["return"]]
    path.write_text(json.dumps(record))
    with pytest.raises(InvalidParameterError, match="checksum mismatch"):
        read_run(path)
    assert load_results(tmp_path).attrs["damaged_runs"] == [path.stem]
    reported = CliRunner().invoke(main, ["report", str(tmp_path)])
    assert reported.exit_code == 0 and "Left out 1 run file(s) that fail their checksum" in (
        reported.output
    )
    assert "fail their checksum and are left out" in (tmp_path / "report.md").read_text()
    capsys.readouterr()
    again = run_experiment(config, tmp_path, max_workers=1, progress=False)
    said = capsys.readouterr().out
    assert "Resume: redoing 1 run(s)" in said and "1 checksum mismatch" in said
    assert again.num_skipped == 1
    redone = read_run(path)["curve"].drop(columns=list(TIMING_COLUMNS))
    pd.testing.assert_frame_equal(redone, original.drop(columns=list(TIMING_COLUMNS)))


def test_a_garbled_npy_header_is_one_error_naming_the_file(tmp_path):
    # Found by tests/test_fuzz.py: numpy's header parser raised a raw tokenize.TokenError.
    directory = _saved_agent(tmp_path)
    npz = directory / "arrays.npz"
    with zipfile.ZipFile(npz) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    weights = bytearray(members["weights.npy"])
    weights[60] ^= 1
    members["weights.npy"] = bytes(weights)
    with zipfile.ZipFile(npz, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    with pytest.raises(InvalidParameterError, match=r"arrays.npz' is damaged"):
        SARSA.restore(directory)


def test_a_sweep_whose_component_params_are_not_a_mapping_is_one_line(tmp_path):
    # Found by tests/test_fuzz.py: a grid key into `params: true` raised a raw TypeError.
    text = TINY + "grid: {agents.q.params.representation.params.num_buckets: [2, 3]}\n"
    path = _write(tmp_path, text.replace("{kind: Tabular}", "{kind: Tabular, params: true}"))
    with pytest.raises(InvalidParameterError, match=r"params` must be a mapping of parameters"):
        load_sweep(path)
