"""Tests of the conjure command line (click's CliRunner)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from conjure.cli.main import main
from conjure.experiments.results import read_run

TINY = textwrap.dedent(
    """\
    name: tiny
    domain: {kind: ChainMDP, params: {num_states: 4, num_actions: 2}}
    agents:
      q:
        kind: QLearning
        params: {representation: {kind: Tabular}, step_size: 0.5}
      sarsa:
        kind: SARSA
        params: {representation: {kind: Tabular}, step_size: 0.5}
    budget_steps: 200
    num_policy_checks: 4
    seeds: 3
    """
)


@pytest.fixture
def config_file(tmp_path):
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return path


def test_list_shows_every_layer_with_its_kinds_on_one_screen():
    from conjure.experiments import registry

    result = CliRunner().invoke(main, ["list"], terminal_width=200)
    assert result.exit_code == 0, result.output
    assert len(result.output.splitlines()) < 40  # was 561 lines at 200 columns
    for layer, components in registry.LAYERS.items():
        assert layer in result.output and f" {len(components)} " in result.output
        assert all(kind in result.output for kind in components)
    assert "fuel_reserve" not in result.output  # parameters only on request
    assert "conjure list planners" in result.output


def test_list_a_layer_shows_its_parameters():
    result = CliRunner().invoke(main, ["list", "planners"], terminal_width=200)
    assert result.exit_code == 0, result.output
    for name in ("ValueIteration", "SampledQAVI", "tolerance"):
        assert name in result.output
    assert "SARSA" not in result.output and "CBBAPlanner" not in result.output
    singular = CliRunner().invoke(main, ["list", "Cooperative-Planner"], terminal_width=200)
    assert "CBBAPlanner" in singular.output and "fuel_reserve" in singular.output


def test_list_search_matches_kinds_and_parameters_in_any_case():
    result = CliRunner().invoke(main, ["list", "--search", "cbba"], terminal_width=200)
    assert result.exit_code == 0, result.output
    assert "CBBAPlanner" in result.output and "fuel_reserve" in result.output
    assert "SARSA" not in result.output
    by_parameter = CliRunner().invoke(main, ["list", "agents", "--search", "trace_decay"])
    assert "SARSA" in by_parameter.output and "LSPI" not in by_parameter.output


def test_list_with_a_bad_layer_or_no_match_is_one_line():
    result = CliRunner().invoke(main, ["list", "plannrs"])
    assert result.exit_code == 2
    assert result.output.startswith("Error: Unknown layer 'plannrs'. Did you mean 'planners'?")
    assert len(result.output.splitlines()) == 1
    nothing = CliRunner().invoke(main, ["list", "--search", "zzz"])
    assert nothing.exit_code == 2 and len(nothing.output.splitlines()) == 1
    assert "No component matches --search 'zzz'" in nothing.output


def test_run_then_plot(config_file, tmp_path):
    out = tmp_path / "out"
    runner = CliRunner()
    result = runner.invoke(
        main,
        [
            "run",
            str(config_file),
            "--seeds",
            "2",
            "--out",
            str(out),
            "--max-workers",
            "1",
            "--set",
            "agents.q.params.step_size=0.25",
        ],
        terminal_width=200,
    )
    assert result.exit_code == 0, result.output
    assert (out / "results.parquet").is_file() and (out / "summary.csv").is_file()
    assert (out / "learning_curve_return.png").is_file()
    runs = [read_run(p)["config"] for p in (out / "runs").glob("*.json")]
    assert sorted((r["label"], r["seed"]) for r in runs if r["label"] == "q") == [
        ("q", 0),
        ("q", 1),
    ]  # --seeds 2 overrides the file's 3
    assert all(r["agent"]["params"]["step_size"] == 0.25 for r in runs if r["label"] == "q")
    assert "sarsa" in result.output and "final return" in result.output
    for shown in ("setting up: ", "plotting the learning curves: "):
        assert shown in result.output  # the phases outside the progress bar

    again = runner.invoke(
        main,
        [
            "run",
            str(config_file),
            "--seeds",
            "2",
            "--out",
            str(out),
            "--max-workers",
            "1",
            "--set",
            "agents.q.params.step_size=0.25",
        ],
        terminal_width=200,
    )
    assert again.exit_code == 0 and "4 finished run(s) were reused" in again.output

    plotted = runner.invoke(main, ["plot", str(out), "--metric", "num_features"])
    assert plotted.exit_code == 0, plotted.output
    assert (out / "learning_curve_num_features.png").is_file()
    for metric in ("failure_rate", "learning_failures"):
        plotted = runner.invoke(main, ["plot", str(out), "--metric", metric])
        assert plotted.exit_code == 0, plotted.output
    no_bounds = runner.invoke(main, ["plot", str(out), "--metric", "optimality"])
    assert no_bounds.exit_code == 2 and "no finite value" in no_bounds.output


def test_run_with_a_memory_limit_runs_in_a_worker_process(config_file, tmp_path):
    import os

    out = tmp_path / "out"
    args = ["run", str(config_file), "--out", str(out), "--max-workers", "1", "--quiet"]
    result = CliRunner().invoke(main, [*args, "--seeds", "1", "--max-memory", "2GiB"])
    assert result.exit_code == 0, result.output
    assert not any(phase in result.output for phase in ("setting up", "plotting"))
    pids = {read_run(path)["meta"]["pid"] for path in (out / "runs").glob("*.json")}
    assert len(pids) == 1 and os.getpid() not in pids
    bad = CliRunner().invoke(main, [*args, "--max-memory", "-3GiB"])
    assert bad.exit_code == 2 and "memory size must be positive" in bad.output


def test_config_error_is_one_clean_line(config_file, tmp_path):
    result = CliRunner().invoke(
        main, ["run", str(config_file), "--out", str(tmp_path / "o"), "--set", "budget_step=5"]
    )
    assert result.exit_code == 2
    assert "Did you mean 'budget_steps'?" in result.output
    assert "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) == 1


def test_malformed_yaml_and_missing_results(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    result = CliRunner().invoke(main, ["run", str(bad)])
    assert result.exit_code == 2 and "malformed YAML" in result.output
    plotted = CliRunner().invoke(main, ["plot", str(tmp_path)])
    assert plotted.exit_code == 2 and "results.parquet" in plotted.output


def test_failed_runs_give_exit_code_1(tmp_path, monkeypatch):
    from test_loop import FakeAgent, FakeWalk

    from conjure.experiments import registry

    monkeypatch.setitem(registry.AGENTS, "FakeAgent", FakeAgent)
    monkeypatch.setitem(registry.DOMAINS, "FakeWalk", FakeWalk)
    path = tmp_path / "fake.yaml"
    path.write_text(
        textwrap.dedent(
            """\
        name: fake
        domain: {kind: FakeWalk}
        agents:
          good: {kind: FakeAgent}
          broken: {kind: FakeAgent, params: {fail_in_setup: true}}
        budget_steps: 50
        seeds: 1
        """
        )
    )
    result = CliRunner().invoke(
        main,
        ["run", str(path), "--out", str(tmp_path / "o"), "--max-workers", "1"],
        terminal_width=200,
    )
    assert result.exit_code == 1, result.output
    assert "broken/seed_0" in result.output and "fake setup failure" in result.output
    assert len(list((tmp_path / "o" / "errors").glob("*.txt"))) == 1
    assert (tmp_path / "o" / "learning_curve_return.png").is_file()


def test_run_on_a_sweep_config_says_so_and_gives_the_sweep_command():
    config = Path(__file__).resolve().parents[2] / "examples/reproduction/fig_5_9_13.yaml"
    result = CliRunner().invoke(main, ["run", str(config)])
    assert result.exit_code == 2
    assert result.output == (
        f"Error: {config} is a sweep config (it has `grid`), not an experiment; run it with "
        f"`conjure sweep {config}`.\n"
    )


def test_invalid_component_value_exits_2(config_file, tmp_path):
    result = CliRunner().invoke(
        main,
        [
            "run",
            str(config_file),
            "--out",
            str(tmp_path / "o"),
            "--max-workers",
            "1",
            "--set",
            "domain.params.num_actions=3",
            "--quiet",
        ],
    )
    assert result.exit_code == 2
    assert "domain.params.num_actions" in result.output


def test_lazy_commands_show_their_own_help_and_run():
    import importlib

    from conjure.cli.main import LAZY_COMMANDS

    listing = CliRunner().invoke(main, ["--help"], terminal_width=200)
    assert listing.exit_code == 0, listing.output
    for name, (module, attribute, text) in LAZY_COMMANDS.items():
        command = getattr(importlib.import_module(module), attribute)
        assert command.help.splitlines()[0] == text  # the table's help is the command's own
        assert f" {name} " in listing.output
        assert command.get_short_help_str() in listing.output
        assert CliRunner().invoke(main, [name, "--help"]).exit_code == 0
    again = CliRunner().invoke(main, ["--help"], terminal_width=200).output
    assert again == listing.output  # loaded commands are listed once, the same way


def test_starting_the_command_line_imports_no_heavy_library():
    import subprocess
    import sys

    code = (
        "import sys; from conjure.cli import main\n"
        "try: main(['--help'])\n"
        "except SystemExit: pass\n"
        "print(sorted(m for m in ('pandas', 'matplotlib', 'scipy.stats', 'numba', "
        "'conjure.experiments.registry') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"


def _unwritable_out(kind, tmp_path):
    if kind == "a file":
        path = tmp_path / "taken"
        path.write_text("not a folder")
        return path
    if kind == "under /proc":
        return Path("/proc/conjure-results")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    # root ignores permission bits; /sys refuses it folders all the same
    return Path("/sys/conjure-results") if os.geteuid() == 0 else locked / "out"


@pytest.mark.parametrize("kind", ["a file", "under /proc", "no permission"])
@pytest.mark.parametrize("command", ["run", "sweep"])
def test_an_unwritable_out_is_one_line_naming_the_path_with_status_2(
    config_file, tmp_path, kind, command
):
    out = _unwritable_out(kind, tmp_path)
    result = CliRunner().invoke(main, [command, str(config_file), "--out", str(out)])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: Cannot write results to ")
    assert repr(str(out)) in lines[0]
    assert "Traceback" not in result.output


def test_plot_draws_the_configured_metric_and_never_replaces_another_metrics_plot(
    config_file, tmp_path
):
    config_file.write_text(config_file.read_text() + "metric: episode_length\n")
    out = tmp_path / "out"
    ran = CliRunner().invoke(main, ["run", str(config_file), "--out", str(out), "--quiet"])
    assert ran.exit_code == 0, ran.output
    drawn = out / "learning_curve_episode_length.png"
    plotted = CliRunner().invoke(main, ["plot", str(out)])
    assert plotted.exit_code == 0 and str(drawn) in plotted.output  # the config's metric
    before = drawn.read_bytes()
    other = CliRunner().invoke(main, ["plot", str(out), "--metric", "return"])
    assert str(out / "learning_curve_return.png") in other.output
    assert drawn.read_bytes() == before  # the episode-length plot is still there, unchanged


LONG_PENDULUM = textwrap.dedent(
    """
    name: long_pendulum
    domain: {kind: InvertedPendulum}
    agents:
      sarsa:
        kind: SARSA
        params:
          representation: {kind: IndependentDiscretization, params: {num_buckets: 20}}
    budget_steps: 1000000000
    num_policy_checks: 1
    seeds: 1
    """
)


@pytest.mark.slow
@pytest.mark.parametrize("workers", ["1", "2"])
def test_ctrl_c_stops_a_run_inside_the_compiled_loop_and_says_what_is_saved(tmp_path, workers):
    # Issue 20: in-process, SIGINT inside the kernel became the run's recorded failure and the
    # sweep went on; with workers, click printed a bare "Aborted!" with status 1.
    from conjure.compiled import warm_up

    # The loop compiled into numba's disk cache first: a cold compile (a minute on a busy
    # 2-core machine) runs in LLVM, where Python sees no signal until it returns.
    warm_up()
    config = tmp_path / "long.yaml"
    config.write_text(LONG_PENDULUM)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "conjure.cli", "run", str(config), "--out", str(out)]
    driver = subprocess.Popen(
        [*command, "--max-workers", workers, "--quiet"],
        env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # Ctrl-C's default disposition, as in a terminal: a suite started in the background by
        # a non-interactive shell (`cmd &`) inherits SIGINT ignored, and so would the driver.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        time.sleep(20.0)  # compiled (or loaded from the cache) and deep in 10⁹ steps
        assert driver.poll() is None
        driver.send_signal(signal.SIGINT)
        interrupted = time.monotonic()
        _, stderr = driver.communicate(timeout=30)
        stopped_after = time.monotonic() - interrupted
    finally:
        driver.kill()
    assert driver.returncode == 130, stderr
    assert stopped_after < 5.0
    assert f"Interrupted: 0 of 1 runs are saved in {out}" in stderr
    assert "Traceback" not in stderr and "Aborted" not in stderr
    assert not (out / "errors").exists()
