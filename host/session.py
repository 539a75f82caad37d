"""One session for ``schmidt-fil run`` and ``schmidt-fil serve``: network, logs, faults, sampling.

A :class:`Session` builds the network of a scenario once (:func:`host.network.build_network`),
opens the four §5.2 logs, ``candump.log`` and (RS232 on) ``telemetry.log``, schedules the
scenario's faults and the host's 10 ms sampling, and advances time on its clock. Run and serve
differ only in the host node (the commanding :class:`host.client.HostClient` or the passive
:class:`host.monitor.BusMonitor`) and in what they do with the session; both run on the same
clock choice — simulated time, or paced to the wall clock on a real bus
(:func:`host.realtime.clock_for`), as SimPy's ``RealtimeEnvironment`` subclasses its
``Environment``. The one stepping loop is :meth:`host.realtime.SimClock.run_until`.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from bus.errors import SimulationError
from bus.scheduler import PRIO_HOST
from host.client import HostClient
from host.logs import CANDUMP_LOG, DISPLAY_LOG, CandumpWriter, HostLogs
from host.maintenance import Maintenance, sensor_columns
from host.realtime import clock_for
from host.rs232 import TELEMETRY_LOG
from host.scenario import Scenario

__all__ = ["Session", "sensor_row", "SAMPLE_PERIOD_US", "SAMPLE_PHASE_US"]

#: Host sampling period of the status data [µs]: the axis controllers publish every 10 ms (paper
#: §3.4: 10 ms samples).
SAMPLE_PERIOD_US = 10_000
#: Phase of the host sampling within the 10 ms period [µs], so each sample holds the latest frame.
SAMPLE_PHASE_US = 5_000


class Session:
    """The network of ``scenario`` with its logs, on its clock.

    Parameters
    ----------
    scenario : Scenario
        Validated scenario.
    out_dir : Path, str or None
        Where the logs go; ``None`` keeps everything in memory (no files).
    host_cls : type
        The host node (:class:`host.client.HostClient` or :class:`host.monitor.BusMonitor`).
    header : str
        First line of the four logs.
    candump_channel : str
        Channel name written into ``candump.log``.
    logs_first : bool
        Open the logs before building the network (``run``: a bad output directory fails before
        anything is built) or after (``serve``: a bus that cannot be opened fails first).

    Attributes
    ----------
    tel : host.network.Telescope
    client : HostClient
    scheduler : bus.scheduler.Scheduler
    paced : bool
        True on SocketCAN: the clock is a :class:`host.realtime.RealtimePacer`.
    clock : host.realtime.SimClock or None
        Made at the first :meth:`advance` (``None`` before).
    errors : list of str
        Simulation errors met (also in ``errors.log``).
    """

    def __init__(self, scenario: Scenario, out_dir: Path | str | None, *, host_cls: type = HostClient,
                 header: str, candump_channel: str = "can0", logs_first: bool = True,
                 build: Callable | None = None) -> None:
        from host.network import build_network

        self.scenario = scenario
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.wall0 = time.perf_counter()
        self.logs: HostLogs | None = None
        self.candump: CandumpWriter | None = None
        self.errors: list[str] = []
        self.samples = 0
        self._sample_hooks: list[Callable[[int], None]] = []
        if logs_first:
            self._open_logs(header)
        try:
            self.tel = (build or build_network)(scenario, host_cls=host_cls)
        except BaseException:
            self._close_files()
            raise
        try:
            for i, f in enumerate(scenario.faults):      # issue 12: not every registry board is built
                if f.board is not None and f.board not in self.tel.boards:
                    from host.scenario import ScenarioError
                    raise ScenarioError(scenario.source_path, None, f"faults[{i}].board",
                                        f"{f.board!r} is not in this network ({', '.join(self.tel.boards)})")
            if not logs_first:
                self._open_logs(header)
            # sim: every frame on the wire; other buses: every frame a monitor receives (a
            # commanding host client has no frame tap there, so no candump.log)
            if self.out_dir is not None and (self.tel.network is not None or hasattr(self.tel.client, "on_frame")):
                self.candump = CandumpWriter(self.out_dir / CANDUMP_LOG, candump_channel)
        except BaseException:
            self._close_files()
            self.tel.close()
            raise
        self.client = self.tel.client
        self.scheduler = self.tel.scheduler
        #: issue 12: the §5.2 maintenance quantities (networks with tachometers / aux encoders)
        self.maintenance = (Maintenance(self.client, scenario.board_names)
                            if sensor_columns(scenario.board_names) else None)
        self.client.logs = self.logs
        if self.candump is not None:
            if self.tel.network is not None:   # sim: every frame on the wire
                self.tel.network.add_tap(self.candump.write)
            else:
                self.client.on_frame = self.candump.write
        if self.out_dir is not None and self.tel.hub is not None:
            self.tel.hub.open_log(self.out_dir / TELEMETRY_LOG)
        if self.out_dir is not None and "display" in self.tel.boards:   # issue 12: the display unit
            self.tel.display_log.open(self.out_dir / DISPLAY_LOG)
        self.paced = scenario.bus.interface == "socketcan"
        self.clock = None   # made at the first advance, so the wall-clock origin is when time starts
        self._sensor_every = max(1, round(1e6 / scenario.log.rate_hz / SAMPLE_PERIOD_US))

    def _open_logs(self, header: str) -> None:
        if self.out_dir is not None:
            self.logs = HostLogs(self.out_dir, header=header,
                                 extra_sensor_columns=sensor_columns(self.scenario.board_names))

    # -- set-up in simulated time ------------------------------------------------------------
    def schedule_faults(self) -> None:
        """Schedule the scenario's injected faults (``at_s`` after now) on the simulated clock."""
        tel = self.tel
        for f in self.scenario.faults:
            t_us = tel.scheduler.now_us + int(round(f.at_s * 1e6))
            tel.scheduler.call_at(t_us, lambda now_us, f=f: tel.inject_fault(f, now_us), priority=PRIO_HOST,
                                  owner=f"fault:{f.kind}")

    def start_sampling(self, owner: str, hook: Callable[[int], None] | None = None) -> None:
        """Sample every 10 ms at phase 5 ms of the 10 ms grid of simulated time (the boards'
        10 ms frames are sent on it): ``hook(now_us)``, then a ``sensor.log`` row at the
        scenario's log rate. The first sample is the first such instant after now (the power-on
        through the USB gateway ends off the 10 ms grid: its SDO reads take one USB frame each
        way)."""
        if hook is not None:
            self._sample_hooks.append(hook)
        now = self.scheduler.now_us
        start = now // SAMPLE_PERIOD_US * SAMPLE_PERIOD_US + SAMPLE_PHASE_US
        if start <= now:
            start += SAMPLE_PERIOD_US
        self.scheduler.call_every(SAMPLE_PERIOD_US, self._sample, start_us=start,
                                  priority=PRIO_HOST, owner=owner)

    def _sample(self, now_us: int) -> None:
        for hook in self._sample_hooks:
            hook(now_us)
        self.samples += 1
        extra = self.maintenance.sample(now_us) if self.maintenance is not None else ()
        if self.logs is not None and self.samples % self._sensor_every == 0:
            self.logs.sensor(now_us, sensor_row(self.client, self.client.setpoints) + extra)

    # -- running -----------------------------------------------------------------------------
    def advance(self, t_us: int | None, should_stop: Callable[[], bool] | None = None,
                on_step: Callable[[], None] | None = None) -> bool:
        """Advance to simulated time ``t_us`` on the session's clock (see
        :meth:`host.realtime.SimClock.run_until`); a simulation error is logged and re-raised.

        Returns
        -------
        bool
            True when ``t_us`` was reached, False when ``should_stop()`` ended it.

        Raises
        ------
        SimulationError
            A board or the plant raised (in ``errors.log``; the logs so far are kept).
        """
        if self.clock is None:
            self.clock = clock_for(self.scenario.bus.interface, self.scheduler.now_us)
        try:
            return self.clock.run_until(self.scheduler, t_us, should_stop, on_step)
        except SimulationError as exc:
            self.errors.append(str(exc))
            if self.logs is not None:
                self.logs.error(self.scheduler.now_us, exc.owner or "simulation", "exception",
                                str(exc).replace("\n", " "))
            raise

    # -- closing -----------------------------------------------------------------------------
    def _close_files(self) -> None:
        """Close every log even if one fails (a full disk); the first error is raised after."""
        first: BaseException | None = None
        for f in (self.logs, self.candump):
            if f is not None:
                try:
                    f.close()
                except BaseException as exc:  # noqa: BLE001 - re-raised below, after the others
                    first = first or exc
        if first is not None:
            raise first

    def close(self) -> None:
        """Close the logs and shut the network down (idempotent; the network is shut down even
        when closing a log fails, and that error is raised after)."""
        try:
            self._close_files()
        finally:
            tel = getattr(self, "tel", None)
            if tel is not None:
                tel.close()

    def files(self) -> list[Path]:
        """Log files written (the four logs, ``candump.log``, ``telemetry.log``)."""
        out: list[Path] = list(self.logs.paths.values()) if self.logs is not None else []
        if self.candump is not None:
            out.append(self.candump.path)
        if self.tel.hub is not None and self.tel.hub.log_path is not None:
            out.append(self.tel.hub.log_path)
        if self.tel.display_log is not None and self.tel.display_log.path is not None:
            out.append(self.tel.display_log.path)
        return out

    def clock_stats(self) -> dict | None:
        """Pacing statistics of the paced clock (``None`` in simulated time)."""
        return self.clock.stats() if self.clock is not None else None

    def wall_s(self) -> float:
        """Wall-clock seconds since the session began."""
        return round(time.perf_counter() - self.wall0, 3)


def sensor_row(client, setpoints: dict) -> tuple:
    """One ``sensor.log`` row (columns :data:`host.logs.SENSOR_COLUMNS`): what the host client
    has decoded from the status frames, with each axis's setpoint.

    Parameters
    ----------
    client : host.client.HostClient
        The host client whose decoded status is logged.
    setpoints : dict
        ``{"ra": ..., "dec": ...}``, the setpoint rate of each axis [arcsec/s].
    """
    row = []
    for axis in ("ra", "dec"):
        st = client.axes[axis]
        row += [st.mode_name, f"{setpoints[axis]:.4f}", st.rate_arcsec_s, st.u, st.counts,
                st.current_a_a, st.current_b_a, client.positions[axis].pos_counts]
    row += [client.focus.pos_halfsteps, client.focus.lvdt_adc]
    return tuple(row)
