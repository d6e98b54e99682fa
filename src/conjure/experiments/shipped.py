"""The example and reproduction configs shipped inside the package (``conjure/examples``).

A checkout's ``examples/*.yaml`` and ``examples/reproduction/`` are links to these files, so
``conjure run examples/pendulum.yaml`` and ``conjure reproduce fig_5_8`` also work from a
wheel, in any folder.

Examples
--------
>>> find_config("examples/pendulum.yaml").name
'pendulum.yaml'
>>> find_config("pendulum").read_text() == find_config("examples/pendulum.yaml").read_text()
True

Notes
-----
- Choice: a path that names an existing file is used as given; only a path that does not exist
  is looked up among the shipped configs, by its part after ``examples/`` (``pendulum``,
  ``pendulum.yaml``, ``examples/pendulum.yaml`` and ``reproduction/fig_5_8`` all work).
"""

from __future__ import annotations

from pathlib import Path

from conjure.core.errors import InvalidParameterError

__all__ = ["EXAMPLES_DIR", "find_config"]

#: The folder of the shipped configs (package data: ``*.yaml`` and ``reproduction/*.yaml``).
EXAMPLES_DIR = Path(__file__).resolve().parents[1] / "examples"


def find_config(path: str | Path) -> Path:
    """``path`` if it names a file, else the shipped config it names (see the module notes).

    Raises `InvalidParameterError` naming ``path`` and where it was looked for.
    """
    given = Path(path)
    if given.is_file():
        return given
    parts = given.parts[1:] if given.parts[:1] == ("examples",) else given.parts
    shipped = EXAMPLES_DIR.joinpath(*parts) if parts else EXAMPLES_DIR
    if shipped.suffix != ".yaml":
        shipped = shipped.with_name(shipped.name + ".yaml")
    if shipped.is_file():
        return shipped
    names = sorted(p.stem for p in EXAMPLES_DIR.glob("*.yaml"))
    raise InvalidParameterError(
        f"No config file {str(path)!r}, here or among the shipped examples ({', '.join(names)};"
        " the reproduction configs: `conjure reproduce --list`)."
    )
