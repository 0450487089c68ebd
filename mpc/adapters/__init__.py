"""Adapters to other robotics ecosystems, each an optional extra.

The core library never imports this package. Import the adapter you need
by its module, e.g. ``from mpc.adapters import wpilib`` (needs
``pip install 'holonomic-mpc[wpilib]'``, i.e. robotpy-wpimath).
"""
