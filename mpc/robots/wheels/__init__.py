"""Wheel types, one module (or one small subpackage, for types with joint states) each.

A wheel type owns its kinematics, its limit rows, its commands and what the rest of the
library asks of it (:class:`~mpc.robots.base.Robot`'s description, mobility wheels, drive
radii, new limits), and registers itself on import (:mod:`mpc.robots.description.registry`:
its factory for robot files, its wheel-set builder, its sweep sampler). Every module here
is imported with this package, so a new type is one new module.
"""

import importlib
import pkgutil

for _module in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_module.name}")
