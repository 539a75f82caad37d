"""What the conformance suite checks against: the published documents, read independently.

The suite is a second, independent host: it knows the network only from what a telescope
engineer is given — ``bus/schmidt.dbc`` (read with cantools), the EDS files of ``bus/eds/``
(read with canopen's ``import_od``), the fault-code table of ``docs/protocol.md`` (parsed from
the page) and the CiA 301 standard (NMT command specifiers, heartbeat states, SDO abort
semantics). It never imports the project's own codecs (``bus.protocol``) or host
(``host.client``); a test in ``tests/test_conformance.py`` checks that.

Tolerances (:class:`Tolerances`) are the suite's, written in docs/conformance.md with their
reasons; none of them was tuned on the emulator's results.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Tuple

__all__ = ["Documents", "KindDoc", "Tolerances", "DEFAULT_TOLERANCES", "NMT_CS", "NMT_STATE",
           "REPO_ROOT", "load_documents"]

#: The repository root (bus/, docs/ next to host/); the defaults of --dbc, --eds-dir, --protocol-doc.
REPO_ROOT = Path(__file__).resolve().parents[2]

#: CiA 301 §7.2.8.3.1 NMT command specifiers.
NMT_CS = {"start": 0x01, "stop": 0x02, "pre-operational": 0x80, "reset node": 0x81,
          "reset communication": 0x82}
#: CiA 301 §7.2.8.3.2 heartbeat states (boot-up = 0).
NMT_STATE = {"boot-up": 0x00, "stopped": 0x04, "operational": 0x05, "pre-operational": 0x7F}


@dataclass(frozen=True)
class Tolerances:
    """Documented acceptance bands of the timing checks (docs/conformance.md, "Tolerances").

    Attributes
    ----------
    period_mean_rel : float
        |mean interval − documented period| / period, at most (0.5 %: a crystal-clocked timer is
        far better; 0.5 % leaves room for the receiver's timestamp resolution).
    pdo_jitter_s : float
        Every interval of a periodic PDO within period ± this, and the 99th percentile of
        |interval − period| within it too, s (2 ms: docs/protocol.md bounds a frame's queueing
        behind higher-priority frames by ≈ 12 frames ≈ 1.6 ms at 1 Mbit/s).
    heartbeat_jitter_s : float
        The same for the heartbeat, s (10 ms: 1 % of the 1 s period; a heartbeat is the lowest
        priority frame and CiA 301 sets no jitter).
    sdo_expedited_s : float
        99th percentile of the expedited SDO upload's answer time (request queued → answer
        received), s (10 ms: the host's 100 ms health-check window holds 5 boards' reads with margin).
    sdo_segmented_s : float
        99th percentile of a whole segmented upload (the device name 0x1008), s (50 ms).
    nmt_reaction_s : float
        A node shows a new NMT state (heartbeat) or stops/starts its PDOs within this after the
        command, plus one heartbeat period where the state is read from the heartbeat, s (50 ms).
    command_reaction_s : float
        An accepted command shows in the node's status PDO within this, s (50 ms: five 10 ms
        status periods).
    rate_rel : float
        A preset's measured mean axis rate (QEI counts over ``rate_window_s``) within this
        fraction of the documented rate (10 %), plus ``rate_abs_arcsec_s``.
    rate_abs_arcsec_s : float
        Absolute part of the rate band, ″/s (5: two QEI counts per 10 ms status period is 2.3″/s).
    rate_window_s : float
        Rate measured over this window after ``settle_s``, s.
    settle_s : float
        Time a preset is given to settle before its rate is measured, s (1 s: the closed loop's
        time constant is tens of ms; a slew step takes ≈ 0.2 s).
    """

    period_mean_rel: float = 0.005
    pdo_jitter_s: float = 0.002
    heartbeat_jitter_s: float = 0.010
    sdo_expedited_s: float = 0.010
    sdo_segmented_s: float = 0.050
    nmt_reaction_s: float = 0.050
    command_reaction_s: float = 0.050
    rate_rel: float = 0.10
    rate_abs_arcsec_s: float = 5.0
    rate_window_s: float = 1.0
    settle_s: float = 1.0


DEFAULT_TOLERANCES = Tolerances()


@dataclass
class KindDoc:
    """One board kind as its EDS describes it.

    Attributes
    ----------
    name : str
        EDS file stem (``axis_controller``).
    path : Path
    device_type_word : int
        Default of 0x1000 (bits 16–23: the paper's device-type byte).
    """

    name: str
    path: Path
    device_type_word: int

    @property
    def device_type(self) -> int:
        """The paper's device-type byte (0x1000 bits 16–23)."""
        return (self.device_type_word >> 16) & 0xFF

    def od(self, node_id: int):
        """canopen object dictionary of this kind for ``node_id`` ($NODEID resolved)."""
        import canopen
        return canopen.import_od(str(self.path), node_id)


@dataclass
class Documents:
    """The DBC, the EDS files and the fault-code table of docs/protocol.md.

    Attributes
    ----------
    dbc : cantools.database.can.Database
    kinds : dict
        Board kinds by EDS stem.
    emcy_codes : dict
        ``{fault name: (fault code, CiA error code, "condition"|"event")}`` from docs/protocol.md.
    """

    dbc: object
    kinds: Dict[str, KindDoc]
    emcy_codes: Dict[str, Tuple[int, int, str]]
    tolerances: Tolerances = field(default_factory=Tolerances)

    def kind_of_device_type(self, device_type: int) -> Optional[KindDoc]:
        """The EDS whose 0x1000 carries ``device_type`` in bits 16–23 (None if none does)."""
        for k in self.kinds.values():
            if k.device_type == device_type:
                return k
        return None

    def message(self, cob_id: int):
        """The DBC message with identifier ``cob_id`` (None if the DBC has none)."""
        try:
            return self.dbc.get_message_by_frame_id(cob_id)
        except KeyError:
            return None

    def fixed_device_type(self, cob_id: int) -> Optional[int]:
        """The value the DBC fixes byte 0 to (signal ``device_type`` with minimum = maximum)."""
        m = self.message(cob_id)
        if m is None:
            return None
        for s in m.signals:
            if s.name == "device_type" and s.start == 0 and s.length == 8:
                if s.minimum is not None and s.minimum == s.maximum:
                    return int(s.minimum)
        return None

    def emcy(self, name: str) -> int:
        """The CiA error code of fault ``name`` (docs/protocol.md, "Fault codes")."""
        try:
            return self.emcy_codes[name][1]
        except KeyError:
            raise KeyError(f"docs/protocol.md documents no fault {name!r}; "
                           f"documented: {sorted(self.emcy_codes)}") from None

    def fault_code(self, name: str) -> int:
        """The project fault code (EMCY byte 3) of fault ``name``."""
        return self.emcy_codes[name][0]


_FAULT_ROW = re.compile(r"^\|\s*(\d+)\s*\|\s*([A-Z_]+)\s*\|\s*0x([0-9A-Fa-f]{4})\s*\((condition|event)\)\s*\|")


def parse_fault_table(text: str, source: str = "docs/protocol.md") -> Dict[str, Tuple[int, int, str]]:
    """The "Fault codes (EMCY b3)" table of docs/protocol.md: ``{name: (code, emcy code, kind)}``.

    Raises
    ------
    ValueError
        When the page has no such table (names the file).
    """
    out: Dict[str, Tuple[int, int, str]] = {}
    for line in text.splitlines():
        m = _FAULT_ROW.match(line.strip())
        if m:
            out[m.group(2)] = (int(m.group(1)), int(m.group(3), 16), m.group(4))
    if not out:
        raise ValueError(f"{source}: no fault-code table (rows '| code | NAME | 0xCODE (condition|event) |')")
    return out


def load_documents(dbc_path: Optional[Path] = None, eds_dir: Optional[Path] = None,
                   protocol_doc: Optional[Path] = None,
                   tolerances: Tolerances = DEFAULT_TOLERANCES) -> Documents:
    """Read the DBC, every ``*.eds`` of ``eds_dir`` and the fault table of the protocol page.

    Raises
    ------
    ValueError
        A file is missing or unreadable (one line naming it).
    """
    import canopen
    import cantools

    dbc_path = Path(dbc_path or REPO_ROOT / "bus" / "schmidt.dbc")
    eds_dir = Path(eds_dir or REPO_ROOT / "bus" / "eds")
    protocol_doc = Path(protocol_doc or REPO_ROOT / "docs" / "protocol.md")
    try:
        dbc = cantools.database.load_file(str(dbc_path))
    except Exception as exc:   # cantools raises several kinds; one line naming the file
        raise ValueError(f"{dbc_path}: cannot load the DBC ({exc})") from None
    kinds: Dict[str, KindDoc] = {}
    files: List[Path] = sorted(eds_dir.glob("*.eds"))
    if not files:
        raise ValueError(f"{eds_dir}: no *.eds files")
    for p in files:
        try:
            od = canopen.import_od(str(p), 1)
            word = int(od[0x1000].default)
        except Exception as exc:
            raise ValueError(f"{p}: cannot load the EDS ({exc})") from None
        kinds[p.stem] = KindDoc(p.stem, p, word)
    try:
        text = protocol_doc.read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"{protocol_doc}: cannot read ({exc.strerror})") from None
    return Documents(dbc, kinds, parse_fault_table(text, str(protocol_doc)), tolerances)
