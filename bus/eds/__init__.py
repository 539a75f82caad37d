"""CANopen object dictionaries (EDS files, CiA 306) of the schmidt-fil board kinds.

The EDS files here are generated from one table, :mod:`bus.eds.objects`
(``python -m bus.eds.generate``); docs/canopen.md explains the objects and the COB-ID plan.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

__all__ = ["eds_path", "load_od", "KINDS"]

from bus.eds.objects import KINDS, kind_spec  # noqa: E402

_DIR = Path(__file__).resolve().parent


def eds_path(kind: str) -> Path:
    """Path of the shipped EDS file of board kind ``kind`` (e.g. ``"axis_controller"``).

    Raises
    ------
    KeyError
        For an unknown kind (the message lists the valid ones).
    """
    kind_spec(kind)
    return _DIR / f"{kind}.eds"


def load_od(kind: str, node_id: Optional[int] = None):
    """``canopen.import_od`` of the kind's EDS for ``node_id`` ($NODEID values resolved)."""
    import canopen
    return canopen.import_od(str(eds_path(kind)), node_id)
