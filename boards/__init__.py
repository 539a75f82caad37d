"""schmidt-fil ``boards``: firmware of the telescope's controller boards and their peripherals.

Boards (paper §3.3-§3.4; node ids from docs/architecture.md):

* :class:`boards.axis_controller.AxisController` — dsPIC30F3011, nodes 1 (RA) and 2 (DEC);
* :class:`boards.position_reader.PositionReader` — PIC18F4480 EnDat reader, nodes 3 and 4;
* :class:`boards.focus_controller.FocusController` — PIC18F4431, node 5;
* issue 12, room nodes: :class:`boards.display.DisplayUnit` (0x0C),
  :class:`boards.dome.DomeController` (0x0D), :class:`boards.weather.WeatherStation` (0x0E).

Peripherals live in :mod:`boards.peripherals`; PI law and drive laws in :mod:`boards.control`;
gain tuning from the plant model in :mod:`boards.tuning`; the EnDat frame in :mod:`boards.endat`.
Which boards the network has (names, node ids, firmware class, plant ports): the registry,
:mod:`boards.registry`. ``boards`` never imports ``plant``: boards meet the plant through port
callables wired by ``host/network.py``.
"""

from __future__ import annotations

import bus  # noqa: F401  (first: its SCHMIDT_FIL_NATIVE switch acts before boards.peripherals loads)
from boards.axis_controller import AxisController, AxisMode, PRESET_RATES_ARCSEC_S
from boards.control import DRIVE_LAWS, IncrementalPI
from boards.firmware_base import Board
from boards.focus_controller import FocusController
from boards.position_reader import PositionReader
from boards.tuning import PiGains, pi_gains_from_model

__all__ = ["AxisController", "AxisMode", "PRESET_RATES_ARCSEC_S", "DRIVE_LAWS", "IncrementalPI",
           "Board", "FocusController", "PositionReader", "PiGains", "pi_gains_from_model"]
