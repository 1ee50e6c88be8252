"""The README's study numbers, generated from a ``results.json`` so that they cannot go stale.

The README holds a block between ``<!-- study-numbers:begin -->`` and ``<!-- study-numbers:end -->``;
:func:`readme_block` renders it from a results file (the summary table and the findings of
:mod:`.findings`), and ``python scripts/readme_numbers.py docs/study-results.json [README.md]``
rewrites it in place (``--check``: exit 1 if the README differs, write nothing).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from robolobes.core.errors import BadInput
from robolobes.core.io import write_text

from .findings import findings, summary_table

__all__ = ["BEGIN", "END", "readme_block", "replace_block", "main"]

BEGIN = "<!-- study-numbers:begin -->"
END = "<!-- study-numbers:end -->"


def readme_block(data: dict, source: str = "docs/study-results.json") -> str:
    """The generated block (markers included) for the results ``data``, read from ``source``."""
    p = data["provenance"]
    kind = "quick" if data["settings"]["quick"] else "full"
    lines = [BEGIN,
             f"*Generated from `{source}` by `python scripts/readme_numbers.py {source}`: computed by robolobes "
             f"{p['robolobes_version']} ({kind} study, {data['generated']}, inputs sha256 {p['inputs_sha256'][:12]}). "
             "Values labelled \"paper\" or given as the paper's are the paper's; every other number is robolobes' "
             "own.*", "", summary_table(data), ""]
    lines += [f"- {s}" for s in findings(data)]
    return "\n".join(lines + [END])


def replace_block(text: str, block: str) -> str:
    """``text`` with its marked block replaced by ``block`` (both markers must be there once)."""
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        raise BadInput(f"the README must hold one {BEGIN} ... {END} block")
    head, rest = text.split(BEGIN, 1)
    return head + block + rest.split(END, 1)[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="readme_numbers", description=(__doc__ or "").splitlines()[0])
    ap.add_argument("results", help="a study's results.json (the committed one: docs/study-results.json)")
    ap.add_argument("readme", nargs="?", default="README.md")
    ap.add_argument("--check", action="store_true", help="exit 1 if the README's block differs; write nothing")
    a = ap.parse_args(argv)
    try:
        data = json.loads(Path(a.results).read_text())
        text = Path(a.readme).read_text()
        new = replace_block(text, readme_block(data, a.results))
    except (OSError, ValueError, KeyError) as e:
        print(f"readme_numbers: error: {e}", file=sys.stderr)
        return 2
    if a.check:
        return 0 if new == text else 1
    if new != text:
        write_text(a.readme, new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
