"""Finds, in LLVM IR as Numba's ``Dispatcher.inspect_llvm()`` gives it, the loops whose
result depends on where their buffers lie in memory: a floating-point reduction (a
vector phi of doubles or floats: the partial sums of a reassociated sum) in a vectorised
loop that runs only when a runtime check finds the buffers it reads and writes apart
(``vector.memcheck``). When the check fails the scalar loop runs instead and sums in
another order, so the same input can give results a few units in the last place apart
from one call to the next (hopmatch._config: such kernels are compiled ``exact``)."""

from __future__ import annotations

import re

_LABEL = re.compile(r"^([A-Za-z_.$][\w.$]*):\s*(?:;\s*preds = (.*))?$")
_FP_VECTOR_PHI = re.compile(r"= phi (?:\w+ )*<\d+ x (?:double|float)>")


def _blocks(function_ir: str) -> dict[str, tuple[list[str], list[str]]]:
    """``{label: (predecessor labels, instruction lines)}`` of one function's IR."""
    blocks: dict[str, tuple[list[str], list[str]]] = {}
    label = None
    for line in function_ir.splitlines():
        m = _LABEL.match(line)
        if m:
            label = m.group(1)
            blocks[label] = (re.findall(r"%([\w.$]+)", m.group(2) or ""), [])
        elif label is not None and line.startswith("  "):
            blocks[label][1].append(line)
    return blocks


def _guarded(blocks, label: str, hops: int = 6) -> bool:
    """Whether a ``vector.memcheck`` block lies within ``hops`` predecessors of ``label``
    (a vector loop's body is entered through its preheader and iteration checks, the
    memory check before them)."""
    seen, frontier = {label}, list(blocks[label][0])
    for _ in range(hops):
        following = []
        for p in frontier:
            if p in seen:
                continue
            seen.add(p)
            if p.startswith("vector.memcheck"):
                return True
            following += blocks.get(p, ([], []))[0]
        frontier = following
    return False


def memory_dependent_reductions(ir: str) -> list[tuple[str, str]]:
    """``(function, vector loop body)`` of every floating-point reduction in a vector
    loop behind a runtime memory check, in the module ``ir``."""
    found = []
    for function in re.split(r"\ndefine ", ir)[1:]:
        name = re.search(r"@([\w.$]+)\(", function).group(1)
        blocks = _blocks(function)
        for label, (_, body) in blocks.items():
            if (label.startswith("vector.body")
                    and any(_FP_VECTOR_PHI.search(line) for line in body)
                    and _guarded(blocks, label)):
                found.append((name, label))
    return found
