"""GridWorld-3 (Section 5.5.3): the extension at other thresholds on the reported seeds.

    cd docs/reproduction && python fig_5_14_thresholds.py > chapter5/fig_5_14_thresholds.csv
    python docs/reproduction/fig_5_14_thresholds.py --thresholds 0.5 --seeds 10005 --budget 300

A post-hoc check, not a selection: ``am_icca_switch_off`` of examples/reproduction/fig_5_14.yaml
at its selected step sizes, with ``trusted_knownness`` set to each of ``--thresholds`` (default
the grid's values other than the selected 0.1, whose runs are stored), on each
of ``--seeds`` (default the 60 reported seeds 10005-10064); prints one CSV row per run (the
final policy check's return and the pit entries while learning). Two processes at once.
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import yaml

CONFIG = Path(__file__).resolve().parents[2] / "examples" / "reproduction" / "fig_5_14.yaml"


def final(threshold: float, seed: int, budget: int | None = None) -> tuple[float, int, float, int]:
    """(threshold, seed, final return, pit entries while learning) of one run."""
    from conjure.experiments.config import parse_config
    from conjure.experiments.run import run_config

    data = yaml.safe_load(CONFIG.read_text())
    for key in ("grid", "selection"):
        data.pop(key)
    if budget is not None:
        data["budget_steps"] = budget
    data["agents"]["am_icca_switch_off"]["params"]["trusted_knownness"] = threshold
    last = run_config(parse_config(data), agent_name="am_icca_switch_off", seed=seed).rows[-1]
    return threshold, seed, float(last["return"]), int(last["learning_failures"])


def main() -> None:
    """Run every threshold on every seed and print the rows."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--thresholds", type=float, nargs="+", default=[0.3, 0.5, 1.0])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(10005, 10065)))
    parser.add_argument("--budget", type=int, default=None, help="default: the config's")
    args = parser.parse_args()
    tasks = [(t, s, args.budget) for t in args.thresholds for s in args.seeds]
    print("threshold,seed,return,learning_failures", flush=True)
    with ProcessPoolExecutor(max_workers=2) as pool:
        for row in pool.map(final, *zip(*tasks, strict=True)):
            print(",".join(map(str, row)), flush=True)


if __name__ == "__main__":
    main()
