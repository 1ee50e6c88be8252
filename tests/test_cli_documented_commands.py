"""Every ``robolobes ...`` command line in README.md and docs/**/*.md still parses and validates.

The command lines are taken from fenced code blocks (``$`` prompts, ``\\`` continuations and
comments handled; a pipe or redirection ends the command). Each runs through the real parser and
every check the command makes before any work, with ``ROBOLOBES_VALIDATE_ONLY=1`` (``robolobes.main``
stops right after the checks: every subcommand registers a ``validate`` hook that makes them, files
read and parsed included), in a fresh directory where the repository's ``tests/data`` and ``cases``
are linked. It must exit 0, or exit 2 only because an input file the documentation
expects the reader to have (or an earlier command to write) is absent, or because no Dask scheduler
listens at an address given as an example. An unknown option, a stale value or a refused flag
combination fails the test, naming the file and line.
"""

import re
import shlex
from pathlib import Path

import pytest

from robolobes.main import main

ROOT = Path(__file__).resolve().parents[1]
_FENCE = re.compile(r"^\s*(```|~~~)")
_ENDS = {"|", ">", ">>", "&&", "||", ";", "2>", "2>&1", "&"}
#: a refusal the test accepts: the documented command names input files the reader provides
_ABSENT = re.compile(r"no such file|does not exist|not found|No such file|cannot read|no measurement set|"
                     r"no Dask scheduler answers")


def documented_commands() -> list[tuple[str, int, list[str]]]:
    """``(file, line, argv)`` of every robolobes command in a fenced block of the docs."""
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("**/*.md"))]
    out = []
    for f in files:
        if not f.is_file():
            continue
        inside, output, buf, start = False, False, "", 0
        for k, line in enumerate(f.read_text(encoding="utf-8").splitlines(), start=1):
            if _FENCE.match(line):
                inside, buf = not inside, ""
                # a ```text block shows output or a synopsis, not a command to run
                output = inside and line.strip().lstrip("`~").strip().lower() == "text"
                continue
            if not inside or output:
                continue
            text = line.strip()
            if not buf:
                start = k
            if text.endswith("\\"):
                buf += text[:-1] + " "
                continue
            text, buf = buf + text, ""
            for part in re.split(r"&&|;|\|\|", re.sub(r"^\$\s+", "", text)):
                argv = _robolobes_argv(part)
                if argv:
                    out.append((str(f.relative_to(ROOT)), start, argv))
    return out


def _robolobes_argv(text: str) -> list[str] | None:
    """The arguments of a ``robolobes`` (or ``.venv/bin/robolobes``) command; None for other text and
    for synopses (``[--opt]``, ``A|B`` alternatives, placeholders in capitals after a flag)."""
    try:
        tokens = shlex.split(text, comments=True)
    except ValueError:
        return None
    if not tokens or Path(tokens[0]).name != "robolobes":
        return None
    argv = []
    for t in tokens[1:]:
        if t in _ENDS or t.startswith(">"):
            break
        argv.append(t)
    if not argv or argv[0].startswith("-") or any(t.startswith("[") or "|" in t for t in argv):
        return None
    return argv


COMMANDS = documented_commands()


def _fresh_dir_like_the_root(tmp_path: Path) -> Path:
    """An empty directory where the repository's shipped inputs (``tests/data``, ``cases``, which
    the docs name "from the repository root") are read-only links, so that a command naming them
    is validated in full, its files read and parsed, and nothing is written into the checkout."""
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "data").symlink_to(ROOT / "tests" / "data", target_is_directory=True)
    (tmp_path / "cases").symlink_to(ROOT / "cases", target_is_directory=True)
    return tmp_path


def test_the_docs_hold_commands():
    assert len(COMMANDS) >= 4, COMMANDS


@pytest.mark.parametrize("where,line,argv", COMMANDS, ids=[f"{w}:{n}" for w, n, _ in COMMANDS])
def test_documented_command_validates(where, line, argv, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("ROBOLOBES_VALIDATE_ONLY", "1")
    monkeypatch.chdir(_fresh_dir_like_the_root(tmp_path))
    try:
        rc = main(argv)
    except SystemExit as e:        # argparse: an unknown option or a bad value
        rc = e.code
    err = capsys.readouterr().err
    if rc == 2 and _ABSENT.search(err) and "usage:" not in err:
        return
    assert rc == 0, f"{where}:{line}: robolobes {shlex.join(argv)}\n{err}"
