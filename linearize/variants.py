"""The names of the built-in model variants (no dependencies: command-line parsers read them).

>>> VARIANTS
('basic', 'gravity', 'orthogonal', 'backlash')
"""

from typing import Literal

__all__ = ["Variant", "VARIANTS"]

Variant = Literal["basic", "gravity", "orthogonal", "backlash"]
VARIANTS: tuple[str, ...] = ("basic", "gravity", "orthogonal", "backlash")
