import os

from conjure.agents import SARSA
from conjure.core.files import write_atomic
from conjure.domains import ChainMDP
from conjure.representations import Tabular


def mode(path):
    return path.stat().st_mode & 0o777


def test_saved_agents_and_results_get_one_mode_the_umask_gives(tmp_path):
    umask = os.umask(0o022)
    try:
        agent = SARSA(representation=Tabular()).setup(ChainMDP().domain_spec, seed=0)
        agent.save(tmp_path / "agent")
        result = write_atomic(tmp_path / "runs" / "x.json", "{}")
    finally:
        os.umask(umask)
    modes = {mode(p) for p in [result, *(tmp_path / "agent").iterdir()]}
    assert modes == {0o644}
    assert not list(tmp_path.rglob("*.tmp-*"))
