"""The thin :class:`Controller` and its collaborators.

- :mod:`.controller`: wiring and the tick (validate, predict, fill, solve, clamp, command);
- :mod:`.settings`: the constructor's settings checked, and the solver they choose;
- :mod:`.measurements`: what ``step()`` receives each tick, checked;
- :mod:`.wheel_output`: the clamped twist as wheel speeds, steer angles and joint rates;
- :mod:`.timing`: which stretch of the reference each plan tracks (time-indexed or scaled);
- :mod:`.warm_start`: the shifted previous plan as the next guess;
- :mod:`.fallback`: what to command when the solver fails;
- :mod:`.delay`: known actuator latency;
- :mod:`.clamp`: the last-line limits clamp;
- :mod:`.command`: :class:`Command` and :class:`Status`;
- :mod:`.slider`: the controller of slider robots (their joint states each tick), which
  ``Controller(robot, ...)`` builds for them.
"""

from mpc.control.clamp import clamp_command
from mpc.control.command import Command, Status
from mpc.control.controller import SOLVERS, Controller
from mpc.control.slider import SliderCommand, SliderController
from mpc.errors import ControllerError as _Error
from mpc.validation import checked_public as _checked_public

__all__ = ["SOLVERS", "Command", "Controller", "SliderCommand", "SliderController", "Status",
           "clamp_command"]

# Arguments that do not fit a public callable's signature raise ControllerError, not TypeError.
_checked_public(globals(), _Error)
