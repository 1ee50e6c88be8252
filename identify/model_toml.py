"""The ``model`` output: the updated case as a case TOML that lobes, simulate and the workspace maps load.

It is the measured case's own file with the identified changes applied: ``[[elements]]`` tables
appended (structural effects), cutting-law keys replaced (``ModelState.overrides``), ``name``
suffixed ``-identified`` and a relative ``robot`` path made absolute. Measurement-chain stages
(sensor dynamics, filters) are properties of the measurement, not of the machine: they are not
written. The writer emits only what TOML case files use (strings, numbers, booleans, arrays,
tables, arrays of tables); an infinite number is TOML's ``inf`` (a one-axis oscillator's
``k2_n_per_m``), a NaN is refused.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

from .effects import ModelState

__all__ = ["model_toml", "dumps"]


def _case_file(ref: str) -> Path:
    from importlib import resources

    p = Path(ref)
    if p.suffix == ".toml" and p.is_file():
        return p.resolve()
    return Path(str(resources.files("robolobes.cases") / "data" / f"{ref}.toml"))


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            raise ValueError(f"cannot write {v} to TOML")
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf")   # TOML's own infinities
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _emit(d: dict, prefix: str, out: list[str]) -> None:
    for k, v in d.items():
        if not isinstance(v, dict) and not _is_table_array(v):
            out.append(f"{k} = {_value(v)}")
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.append(f"\n[{name}]")
            _emit(v, name + ".", out)
        elif _is_table_array(v):
            for item in v:
                out.append(f"\n[[{name}]]")
                _emit(item, name + ".", out)


def dumps(d: dict) -> str:
    """A TOML document for the dict ``d`` (round-trips through ``tomllib``)."""
    out: list[str] = []
    _emit(d, "", out)
    return "\n".join(out).lstrip("\n") + "\n"


def model_toml(state: ModelState) -> str:
    """The case TOML of ``state`` (see the module doc)."""
    from robolobes.linearize.extra_elements import spec_table

    src = _case_file(state.case_ref or state.case.name)
    with open(src, "rb") as fh:
        data = tomllib.load(fh)
    robot = data.get("robot")
    if isinstance(robot, str) and robot.endswith(".toml") and not Path(robot).is_absolute():
        data["robot"] = str((src.parent / robot).resolve())
    data["name"] = f"{data.get('name', src.stem)}-identified"
    for table, key, value in state.overrides:
        data.setdefault(table, {})[key] = value
    elements = list(data.get("elements", []))
    for spec in state.elements:
        elements.append(spec_table(spec))
    if elements:
        data["elements"] = elements
    head = (f"# {data['name']}: case {state.case_ref or state.case.name} updated by robolobes identify "
            f"(variant {state.variant})\n")
    return head + dumps(data)
