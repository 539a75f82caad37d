"""Plant models of the ARIES 50/80 cm Schmidt telescope: axes (twin motors, gear trains, LuGre) and focus.

Public API: :func:`load_parameters`, :func:`dump_parameters`, :class:`ParameterError`,
:class:`AxisPlant`, :class:`FocusPlant`. No wall clock, sleeps or threads; never imports
``boards`` or ``bus``. See docs/plant.md.
"""

from plant.params import (
    AxisParameters,
    FocusParameters,
    ParameterError,
    PlantParameters,
    dump_parameters,
    load_parameters,
)
from plant.axis import ARCSEC_PER_RAD, AxisPlant
from plant.focus import FocusPlant

__all__ = [
    "ARCSEC_PER_RAD",
    "AxisParameters",
    "AxisPlant",
    "FocusParameters",
    "FocusPlant",
    "ParameterError",
    "PlantParameters",
    "dump_parameters",
    "load_parameters",
]
