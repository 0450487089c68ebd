"""Both solver paths behind one protocol (:class:`TrackingSolver`).

- :mod:`.qp`: the OSQP real-time-iteration fast path; its QP is assembled
  once by the pure function :func:`~.qp_structure.assemble_qp`.
- :mod:`.nlp`: the exact IPOPT path (the yardstick).
"""

from mpc.solvers.base import SolveResult, TrackingSolver
from mpc.solvers.nlp import NlpSolver
from mpc.solvers.qp import USABLE_DUAL_RESIDUAL, USABLE_PRIMAL_RESIDUAL, QpSolver
from mpc.solvers.qp_structure import QpStructure, assemble_qp

__all__ = [
    "USABLE_DUAL_RESIDUAL",
    "USABLE_PRIMAL_RESIDUAL",
    "NlpSolver",
    "QpSolver",
    "QpStructure",
    "SolveResult",
    "TrackingSolver",
    "assemble_qp",
]
