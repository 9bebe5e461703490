"""Type stubs of the Rust extension (see ``python/src/lib.rs``); use the functions of the
``blossomquad`` package instead."""

from typing import Callable, List, Optional, Sequence, Tuple

__version__: str

class Error(ValueError):
    """A mesh blossomquad cannot read, recombine or write (the command line's message)."""

_Progress = Optional[Callable[[str, int, int], None]]

def cli(argv: List[str]) -> int: ...
def recombine_file(input: str, output: str, options: str, progress: _Progress = None) -> str: ...
def quadrangulate_arrays(
    points: bytes, triangles: bytes, fixed: bytes, options: str, progress: _Progress = None
) -> Tuple[bytes, bytes, str]: ...
def recombine_model(
    entities: Sequence[Tuple[int, int, List[float], List[int], List[int]]],
    names: Sequence[Tuple[int, int, str]],
    nodes: Sequence[Tuple[int, int, bytes, bytes]],
    elements: Sequence[Tuple[int, int, int, bytes, bytes]],
    periodic: Sequence[Tuple[int, int, int, List[float], bytes, bytes]],
    options: str,
    progress: _Progress = None,
) -> Tuple[
    List[Tuple[int, int, str, bytes, bytes, List[Tuple[int, bytes, bytes]]]], str, float
]: ...
