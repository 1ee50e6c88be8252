# pinocchio's PyPI wheel is a compiled extension without type information: every name it exports
# is typed Any for pyright (checks of robolobes' own code are unaffected).
from typing import Any

def __getattr__(name: str) -> Any: ...
