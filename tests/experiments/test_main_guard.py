import ast
import os
import subprocess
import sys
import textwrap

import pytest

from conjure.experiments.main_guard import _is_guarded

POOL = textwrap.dedent(
    """\
    from conjure.experiments.executors import LocalExecutor

    def main():
        with LocalExecutor(max_workers=2) as executor:
            print(sorted(executor.map_unordered(abs, [-1, 2])))
    """
)


@pytest.mark.parametrize(
    ("tail", "guarded"),
    [
        ("main()\n", False),
        ('if __name__ == "__main__":\n    main()\n', True),
        ("if '__main__' == __name__:\n    x = 1\n    main()\n", True),
        ('if __name__ != "__main__":\n    main()\n', False),
    ],
)
def test_a_call_is_guarded_only_under_if_name_main(tail, guarded):
    source = POOL + tail
    line = len(source.splitlines())
    assert _is_guarded(ast.parse(source), line) is guarded


def run_script(tmp_path, source):
    script = tmp_path / "script.py"
    script.write_text(source)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
        timeout=120,
    )  # fmt: skip


def test_a_pool_started_at_a_scripts_top_level_fails_fast_with_the_fix(tmp_path):
    done = run_script(tmp_path, POOL + "main()\n")
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert "script.py, line 6," in last and 'if __name__ == "__main__":' in last
    guarded = run_script(tmp_path, POOL + 'if __name__ == "__main__":\n    main()\n')
    assert guarded.returncode == 0, guarded.stderr
    assert guarded.stdout.strip() == "[(0, 1), (1, 2)]"
