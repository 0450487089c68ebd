"""The solver paths behind one protocol (:class:`TrackingSolver`).

- :mod:`.dense`: daqp on the QP condensed onto the inputs (:mod:`.condensed`), its
  Hessian rebuilt only when the terms moved (:mod:`.hessian_reuse`);
- :mod:`.qp`: OSQP on the sparse QP, assembled once by the pure function
  :func:`~.qp_structure.assemble_qp` (which the condensed path starts from too);
- :mod:`.nlp`: the exact IPOPT path (the yardstick).
"""

from mpc.solvers.base import SolveResult, TrackingSolver
from mpc.solvers.dense import DenseSolver
from mpc.solvers.nlp import NlpSolver
from mpc.solvers.qp import USABLE_DUAL_RESIDUAL, USABLE_PRIMAL_RESIDUAL, QpSolver
from mpc.solvers.qp_structure import QpStructure, assemble_qp

__all__ = [
    "USABLE_DUAL_RESIDUAL",
    "USABLE_PRIMAL_RESIDUAL",
    "DenseSolver",
    "NlpSolver",
    "QpSolver",
    "QpStructure",
    "SolveResult",
    "TrackingSolver",
    "assemble_qp",
]
