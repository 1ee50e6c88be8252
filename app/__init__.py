"""robolobes: dynamics of robotic milling.

Subpackages, in data-flow order (each imports only those before it)::

    robolobes.core        shared types and helpers: Verdict, BadInput, validation, numerics, atomic I/O
    robolobes.cases       robots, tools, materials, cuts and toolpaths as data; the milling force law
    robolobes.linearize   the configuration-dependent flexible robot, kinematics, modes, tool-tip FRFs
    robolobes.lobes       stability lobes (semi-discretization, zero-order approximation)
    robolobes.timedomain  Newmark simulation of the nonlinear robot with regenerative milling
    robolobes.identify    measured data in, residual, missing effect, refit
    robolobes.study       the aluminium-versus-steel study of the TX200 (``robolobes study``)
    robolobes.workspace   lobe maps over poses and placements, pose and placement optimization

The command line is :func:`robolobes.main.main` (``robolobes ...`` or ``python -m robolobes ...``).
"""

if __name__ != "robolobes":  # this folder imported by itself (from the repository root): a second copy
    raise ImportError(f"{__name__!r} is the folder of the robolobes package: import robolobes instead")



def __getattr__(name: str) -> str:
    """``robolobes.__version__``, read from the installed metadata on first use (importlib.metadata
    costs more start-up time than ``robolobes --help`` itself, so it is not imported before)."""
    if name != "__version__":
        raise AttributeError(f"module 'robolobes' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("robolobes")
    except PackageNotFoundError:  # running from a source tree that was not installed
        value = "0+unknown"
    globals()["__version__"] = value
    return value
