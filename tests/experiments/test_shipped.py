from pathlib import Path

import pytest

from conjure.core.errors import InvalidParameterError
from conjure.experiments.shipped import EXAMPLES_DIR, find_config

ROOT = Path(__file__).resolve().parents[2]


def test_checkout_examples_are_the_shipped_files():
    for name in ("pendulum.yaml", "reproduction/fig_5_8.yaml"):
        assert (ROOT / "examples" / name).resolve() == (EXAMPLES_DIR / name).resolve()


@pytest.mark.parametrize(
    "given", ["pendulum", "pendulum.yaml", "examples/pendulum.yaml", "examples/pendulum"]
)
def test_a_missing_path_finds_the_shipped_config(tmp_path, monkeypatch, given):
    monkeypatch.chdir(tmp_path)
    assert find_config(given) == EXAMPLES_DIR / "pendulum.yaml"
    assert find_config("reproduction/fig_5_8") == EXAMPLES_DIR / "reproduction" / "fig_5_8.yaml"


def test_an_existing_file_wins_and_an_unknown_name_is_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "pendulum.yaml").write_text("name: mine\n")
    assert find_config("pendulum.yaml") == Path("pendulum.yaml")
    with pytest.raises(InvalidParameterError, match=r"'penduluum'.*shipped examples.*pendulum"):
        find_config("penduluum")
