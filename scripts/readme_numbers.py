"""Regenerate the README's study numbers from a results file: ``python scripts/readme_numbers.py
docs/study-results.json [README.md] [--check]`` (see :mod:`robolobes.study.readme`)."""

import sys

from robolobes.study.readme import main

if __name__ == "__main__":
    sys.exit(main())
