"""``robolobes export-urdf``: write a robot as a URDF plus the robot TOML of what the URDF lacks.

The output directory (``--out``, through :class:`robolobes.core.outdir.OutputDir`: nothing a user
owns is overwritten) receives ``<name>.urdf`` and ``<name>.toml``; loading the TOML
(``--case`` files name it with ``robot = "<dir>/<name>.toml"``) gives the same robot, in the
same controller angles (:mod:`robolobes.linearize.urdf`).
"""

from __future__ import annotations

import dataclasses
import re

__all__ = ["register", "run_export_urdf", "validate_export_urdf"]


def _stem(name: str) -> str:
    """A file name stem from a robot name: ``"Staubli TX200"`` -> ``"staubli-tx200"``."""
    return re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-") or "robot"


def _robot_and_out(args):
    from robolobes.cases import load_robot
    from robolobes.core.outdir import OutputDir, cli_inputs

    spec = load_robot(args.robot)
    inputs = {**cli_inputs(args), "robot": dataclasses.asdict(spec)}
    return spec, OutputDir(args.out, "export-urdf", inputs)


def validate_export_urdf(args) -> None:
    """Every check made before any work: the robot file and the output directory."""
    _robot_and_out(args)


def run_export_urdf(args) -> int:
    from pathlib import Path

    from robolobes.core.outdir import provenance_text

    from .urdf_export import robot_toml, write_urdf

    spec, out = _robot_and_out(args)
    stem = _stem(spec.name)
    header = f"written by robolobes export-urdf from robot {spec.name!r}; " + provenance_text(out.provenance)
    urdf, toml = write_urdf(spec, header), robot_toml(spec, f"{stem}.urdf", header)
    with out:  # OSErrors inside become one line naming --out (OutputDir)
        staging = Path(str(out.path))
        (staging / f"{stem}.urdf").write_text(urdf)
        (staging / f"{stem}.toml").write_text(toml)
    print(f"wrote {out.target / (stem + '.urdf')} and {out.target / (stem + '.toml')}")
    return 0


def register(sub) -> None:
    p = sub.add_parser("export-urdf", help="write a robot as a URDF plus the TOML of what the URDF lacks",
                       description="Write a robot (built-in name or robot TOML) as a URDF in controller angles "
                                   "(sign 1, offset 0) and the robot TOML of its flexibility, payload and poses, "
                                   "which loads back to the same model.")
    p.add_argument("--robot", default="tx200", help="built-in robot name or path of a robot TOML (default tx200)")
    p.add_argument("--out", required=True, help="output directory (new, or one robolobes wrote from the same inputs)")
    p.set_defaults(run=run_export_urdf, validate=validate_export_urdf)
