"""CANopen services (CiA 301) composed into a board, in simulated time, on the canopen library.

As canopen's ``LocalNode`` composes NMT, SDO, PDO and EMCY over an object dictionary, a board
composes one :class:`CanopenDevice` and implements :class:`Application` (read/write callbacks for
its objects, NMT and reset hooks). docs/canopen.md describes the interface and the COB-ID plan.

Modules: ``network`` (canopen Network without bus or threads), ``sdo`` (robust SDO server),
``heartbeat`` (producer and consumer on the scheduler), ``emcy`` (EMCY, 0x1001, 0x1003),
``application`` (the firmware interface), ``device`` (the composition).
"""

from boards.services.application import Application, ObjectRefused
from boards.services.device import CanopenDevice

__all__ = ["CanopenDevice", "Application", "ObjectRefused"]
