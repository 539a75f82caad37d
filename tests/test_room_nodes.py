"""Issue 12, the room nodes: display unit (0x0C), dome controller (0x0D), weather station (0x0E).

Frames are checked against their documented layouts (docs/protocol.md) with cantools decoding
the DBC, not only the project's codecs; the dome's azimuth against an independent vector
rotation; its limits on a test-owned integrator; the weather flags with test-owned sensor
signals; the host's weather handling on the whole network.
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from boards.display import DisplayUnit, format_dms, format_hms
from boards.dome import DomeController, slit_azimuth_deg
from boards.weather import WeatherStation
from bus import protocol as P
from bus.scheduler import PRIO_PLANT, Scheduler
from plant.params import load_parameters
from plant.weather import WeatherEvent, WeatherModel
from tests.boards_fakes import FakeBus, nmt_start

PARAMS = load_parameters()
POS_REV = 1 << 29


def _dbc():
    return P.load_dbc()


def _pos_counts(deg: float) -> int:
    return int(round(deg / 360.0 * POS_REV)) % POS_REV


# ------------------------------------------------------------------------------------------------
# frames: the documented byte layouts, decoded by cantools
# ------------------------------------------------------------------------------------------------

def test_room_frames_have_the_documented_ids_and_layouts():
    """DOME_STATUS, DOME_COMMAND, WEATHER_STATUS and DISPLAY_STATUS have the COB-IDs of the
    pre-defined connection set and decode with cantools to the documented physical values."""
    db = _dbc()
    assert (P.display_status_cob_id(), P.dome_status_cob_id(), P.dome_command_cob_id(),
            P.weather_status_cob_id()) == (0x18C, 0x18D, 0x20D, 0x18E)
    # bytes packed from the docs/protocol.md tables by hand (little-endian)
    dome = bytes([0x07, 1, 0b0011]) + struct.pack("<HH", 12345, 18000) + b"\x00"
    m = db.decode_message(0x18D, dome)
    assert m["azimuth"] == pytest.approx(123.45) and m["target_azimuth"] == pytest.approx(180.0)
    assert (m["moving"], m["on_target"], m["parked"], m["position_stale"]) == (1, 1, 0, 0)
    assert P.decode_dome_status(dome) == (P.DomeMode.FOLLOW, 3, 12345, 18000)
    wx = bytes([0x08, 0b10]) + struct.pack("<hHH", -512, 9150, 1725)
    m = db.decode_message(0x18E, wx)
    assert (m["temperature"], m["humidity"], m["wind_speed"]) == pytest.approx((-5.12, 91.5, 17.25))
    assert (m["high_wind"], m["rain"]) == (0, 1)
    cmd = bytes([0x10, 2, 0, 0]) + struct.pack("<i", 27000)
    m = db.decode_message(0x20D, cmd, decode_choices=False)
    assert (m["cmd"], m["value"]) == (2, 27000)
    assert P.encode_dome_command(P.DomeCommand.GOTO, 27000) == cmd
    disp = bytes([0x06, 0b0101]) + struct.pack("<HH", 40000, 17) + b"\x00\x00"
    m = db.decode_message(0x18C, disp)
    assert (m["frames_received"], m["refreshes"], m["ra_position_stale"], m["ra_axis_stale"]) == (40000, 17, 1, 1)


@settings(max_examples=60, deadline=None)
@given(mode=st.integers(0, 3), flags=st.integers(0, 15), az=st.integers(0, 35999), tgt=st.integers(0, 35999),
       t=st.integers(-32768, 32767), h=st.integers(0, 10000), w=st.integers(0, 65535))
def test_room_status_frames_round_trip_through_cantools(mode, flags, az, tgt, t, h, w):
    """Our encoders and cantools agree on every field of DOME_STATUS and WEATHER_STATUS."""
    db = _dbc()
    d = db.decode_message(0x18D, P.encode_dome_status(mode, flags, az, tgt), scaling=False, decode_choices=False)
    assert (d["mode"], d["azimuth"], d["target_azimuth"]) == (mode, az, tgt)
    assert sum(d[n] << i for i, n in enumerate(("moving", "on_target", "parked", "position_stale"))) == flags
    raw = db.encode_message(0x18E, {"device_type": 8, "high_wind": flags & 1, "rain": (flags >> 1) & 1,
                                    "temperature": t, "humidity": h, "wind_speed": w}, scaling=False)
    assert P.decode_weather_status(raw) == (flags & 3, t, h, w)


def test_malformed_room_frames_are_refused_by_the_decoders():
    """A wrong device type, azimuth beyond 359.99° or humidity beyond 100 % is a MalformedFrame."""
    from bus.errors import MalformedFrame
    with pytest.raises(MalformedFrame):
        P.decode_dome_status(bytes([0x01, 0, 0, 0, 0, 0, 0, 0]))
    with pytest.raises(MalformedFrame):
        P.decode_dome_status(bytes([0x07, 0, 0]) + struct.pack("<HH", 36000, 0) + b"\0")
    with pytest.raises(MalformedFrame):
        P.decode_weather_status(bytes([0x08, 0]) + struct.pack("<hHH", 0, 10001, 0))
    with pytest.raises(MalformedFrame):
        P.decode_dome_command(bytes([0x10, 9, 0, 0, 0, 0, 0, 0]))


# ------------------------------------------------------------------------------------------------
# dome: azimuth from HA/DEC, following with its limits, refusals
# ------------------------------------------------------------------------------------------------

def _azimuth_by_rotation(ha_deg, dec_deg, lat_deg):
    """Independent: the direction as a vector in the equatorial (HA, DEC) frame, rotated about
    the east-west axis by the colatitude into (north, east, up)."""
    h, d, p = np.radians([ha_deg, dec_deg, lat_deg])
    # equatorial frame: x toward (H = 0, δ = 0) i.e. the meridian on the equator, y toward
    # H = -90° (east), z the celestial pole
    v = np.array([np.cos(d) * np.cos(h), -np.cos(d) * np.sin(h), np.sin(d)])
    # the pole is at altitude φ in the north; the equator's meridian point at altitude 90° − φ south
    south = np.array([np.sin(p), 0.0, -np.cos(p)])        # components of the horizon "south" axis
    up = np.array([np.cos(p), 0.0, np.sin(p)])
    east = np.array([0.0, 1.0, 0.0])
    n, e = -v @ south, v @ east
    return math.degrees(math.atan2(e, n)) % 360.0


def _horizontal_norm(ha_deg, dec_deg, lat_deg):
    """cos(altitude) of the direction (0 at the zenith, where the azimuth is undefined)."""
    h, d, p = np.radians([ha_deg, dec_deg, lat_deg])
    up = np.cos(d) * np.cos(h) * np.cos(p) + np.sin(d) * np.sin(p)
    return math.sqrt(max(0.0, 1.0 - up * up))


@settings(max_examples=200, deadline=None)
@given(ha=st.floats(-180, 180), dec=st.floats(-89, 89), lat=st.floats(-80, 80))
def test_slit_azimuth_agrees_with_a_vector_rotation(ha, dec, lat):
    """slit_azimuth_deg (atan2 formula) equals the azimuth of the rotated direction vector."""
    a, b = slit_azimuth_deg(ha, dec, lat), _azimuth_by_rotation(ha, dec, lat)
    if _horizontal_norm(ha, dec, lat) < 1e-6:
        return   # at the zenith the azimuth is undefined
    assert abs((a - b + 180) % 360 - 180) < 1e-6


def test_slit_azimuth_known_directions_at_the_site():
    """On the meridian a star south of the zenith is due south, the pole due north; rising stars
    are east (H < 0), setting ones west."""
    lat = PARAMS.site.latitude_deg
    assert slit_azimuth_deg(0, 0, lat) == pytest.approx(180)
    assert slit_azimuth_deg(0, 89.999, lat) == pytest.approx(0, abs=1e-2) or \
        slit_azimuth_deg(0, 89.999, lat) == pytest.approx(360, abs=1e-2)
    assert 0 < slit_azimuth_deg(-30, 10, lat) < 180 < slit_azimuth_deg(30, 10, lat) < 360


class _DomeRig:
    """A dome controller on a fake bus, its drive integrated by the test (not plant/dome.py)."""

    def __init__(self, **over):
        d = PARAMS.dome
        self.s = Scheduler()
        self.bus = FakeBus()
        self.az = 0.0                  # deg, unwrapped
        self.rate = 0.0
        self.t = 0
        self.log = []                  # (t_us, rate deg/s) at every reference change
        kw = dict(latitude_deg=PARAMS.site.latitude_deg, max_rate_deg_s=d.max_rate_deg_s,
                  acceleration_deg_s2=d.acceleration_deg_s2, deadband_deg=d.deadband_deg,
                  park_azimuth_deg=d.park_azimuth_deg, vfd_full_scale_deg_s=d.vfd_full_scale_deg_s,
                  encoder_counts_per_rev=d.encoder_counts_per_rev, dac_bits=d.dac_bits,
                  control_period_us=d.control_period_us, position_timeout_us=d.position_timeout_us)
        kw.update(over)
        self.dome = DomeController(self.s, self.bus, read_azimuth_counts=self._counts,
                                   set_speed_reference=self._ref, **kw)
        self.dome.start()
        nmt_start(self.dome)

    def _advance(self):
        now = self.s.now_us
        self.az += self.rate * (now - self.t) * 1e-6
        self.t = now

    def _counts(self):
        self._advance()
        n = PARAMS.dome.encoder_counts_per_rev
        return int((self.az % 360.0) / 360.0 * n)

    def _ref(self, f):
        self._advance()
        self.rate = f * PARAMS.dome.vfd_full_scale_deg_s
        self.log.append((self.s.now_us, self.rate))

    def command(self, cmd, value=0):
        self.bus.inject(P.dome_command_cob_id(), P.encode_dome_command(cmd, value))

    def positions(self, ha_of_t, dec_deg, t_end_us):
        """Inject POSITION frames of both readers every 10 ms until ``t_end_us``."""
        def send(now):
            self.bus.inject(P.position_cob_id(P.NodeId.RA_READER), P.encode_position(0, 0, _pos_counts(ha_of_t(now))))
            self.bus.inject(P.position_cob_id(P.NodeId.DEC_READER), P.encode_position(0, 0, _pos_counts(dec_deg)))
        ev = self.s.call_every(10_000, send, start_us=self.s.now_us, priority=PRIO_PLANT)
        self.s.run_until(t_end_us)
        self.s.cancel(ev)


def _check_limits(log, period_us, dome_params, quantum):
    rates = [r for _, r in log]
    assert max(abs(r) for r in rates) <= dome_params.max_rate_deg_s + 1e-9
    dv = dome_params.acceleration_deg_s2 * period_us * 1e-6 + quantum + 1e-9
    steps = [abs(b - a) for a, b in zip([0.0] + rates, rates)]
    assert max(steps) <= dv
    return max(abs(r) for r in rates)


def test_dome_follows_a_slew_within_its_rate_and_acceleration_limits():
    """FOLLOW during a 2°/s RA slew from HA −40° to +40° at DEC 45°: the dome never exceeds its
    rate or acceleration limit, reaches its full rate, and ends within the deadband of the
    azimuth computed independently for the final position."""
    rig = _DomeRig()
    lat, dec = PARAMS.site.latitude_deg, 45.0
    rig.command(P.DomeCommand.FOLLOW)
    ha = lambda t_us: max(-40.0, min(40.0, -40.0 + 2.0 * (t_us - 1_000_000) * 1e-6))  # noqa: E731
    rig.positions(ha, dec, 90_000_000)
    q = PARAMS.dome.vfd_full_scale_deg_s / ((1 << (PARAMS.dome.dac_bits - 1)) - 1)
    peak = _check_limits(rig.log, PARAMS.dome.control_period_us, PARAMS.dome, q)
    assert peak == pytest.approx(PARAMS.dome.max_rate_deg_s, abs=q)   # the limit was reached
    final = _azimuth_by_rotation(40.0, dec, lat)
    err = (rig.az - final + 180) % 360 - 180
    assert abs(err) <= PARAMS.dome.deadband_deg
    assert rig.rate == 0.0 and not rig.dome.moving
    st_frames = [P.decode_dome_status(m.data) for m in rig.bus.frames(P.dome_status_cob_id())]
    assert st_frames[-1].mode == P.DomeMode.FOLLOW and st_frames[-1].flags & P.DomeFlags.ON_TARGET
    assert abs((st_frames[-1].azimuth_cdeg / 100 - rig.az % 360 + 180) % 360 - 180) < 0.02


def test_dome_holds_and_flags_stale_positions():
    """FOLLOW without POSITION frames: no motion and POSITION_STALE in DOME_STATUS."""
    rig = _DomeRig()
    rig.command(P.DomeCommand.FOLLOW)
    rig.s.run_until(2_000_000)
    assert rig.rate == 0.0 and rig.az == 0.0
    last = P.decode_dome_status(rig.bus.frames(P.dome_status_cob_id())[-1].data)
    assert last.flags & P.DomeFlags.POSITION_STALE and not last.flags & P.DomeFlags.MOVING


def test_dome_goto_out_of_range_is_refused_and_changes_nothing():
    """GOTO 360.00° is refused with EMCY COMMAND_REFUSED (reason 7, command 2); the mode and
    target stay as they were; a valid GOTO then runs to the target and PARK parks."""
    rig = _DomeRig()
    rig.command(P.DomeCommand.GOTO, 9000)
    rig.s.run_until(1_000_000)
    before = (rig.dome.mode, rig.dome.goto_deg)
    rig.command(P.DomeCommand.GOTO, 36000)
    rig.command(P.DomeCommand.GOTO, -1)
    emcy = [_dbc().decode_message(m.arbitration_id, m.data, decode_choices=False)
            for m in rig.bus.frames(P.emcy_cob_id(P.NodeId.DOME))]
    refused = [e for e in emcy if e["fault_code"] == int(P.FaultCode.COMMAND_REFUSED)]
    assert len(refused) == 2 and all(e["detail"] == (7 << 8) | 2 for e in refused)
    assert (rig.dome.mode, rig.dome.goto_deg) == before
    rig.s.run_until(60_000_000)
    assert abs(rig.az - 90.0) <= 0.2 and rig.rate == 0.0
    rig.command(P.DomeCommand.PARK)
    rig.s.run_until(120_000_000)
    last = P.decode_dome_status(rig.bus.frames(P.dome_status_cob_id())[-1].data)
    assert last.mode == P.DomeMode.PARK and last.flags & P.DomeFlags.PARKED
    assert abs(rig.az % 360 - PARAMS.dome.park_azimuth_deg) <= 0.2


def test_dome_stop_all_ramps_down_at_the_acceleration_limit():
    """STOP_ALL during a move: the rate falls to zero no faster than the acceleration limit."""
    rig = _DomeRig()
    rig.command(P.DomeCommand.GOTO, 18000)
    rig.s.run_until(10_000_000)
    assert abs(rig.rate) == pytest.approx(PARAMS.dome.max_rate_deg_s, abs=0.01)
    rig.bus.inject(P.stop_all_cob_id(), P.encode_stop_all())
    rig.s.run_until(20_000_000)
    assert rig.rate == 0.0 and rig.dome.mode == P.DomeMode.IDLE
    q = PARAMS.dome.vfd_full_scale_deg_s / ((1 << (PARAMS.dome.dac_bits - 1)) - 1)
    _check_limits(rig.log, PARAMS.dome.control_period_us, PARAMS.dome, q)
    t_stop = next(t for t, r in rig.log if t > 10_000_000 and r == 0.0)
    assert t_stop - 10_000_000 >= (PARAMS.dome.max_rate_deg_s / PARAMS.dome.acceleration_deg_s2 - 0.1) * 1e6


# ------------------------------------------------------------------------------------------------
# weather: the seeded series and the station's flags
# ------------------------------------------------------------------------------------------------

def test_weather_series_is_seeded_and_has_the_documented_statistics():
    """Same seed → same series; another seed → another; over 6 h the wind and humidity have the
    parameter file's mean and spread (within sampling error of the correlated process)."""
    p = PARAMS.weather

    def series(seed, n):
        w = WeatherModel(p, seed)
        out = []
        for k in range(n):
            w.advance_to(k * p.sample_period_us)
            out.append((w.temperature_c, w.humidity_pct, w.wind_m_s, w.rain))
        return np.array(out, dtype=float)

    a, b, c = series(7, 300), series(7, 300), series(8, 300)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    n = 6 * 3600
    x = series(11, n)
    wind = x[:, 2]
    # effective samples of an AR(1) with time constant tau: n / (2 tau / step)
    n_eff = n / (2 * p.wind_tau_s / (p.sample_period_us * 1e-6))
    assert abs(wind.mean() - p.wind_mean_m_s) < 5 * p.wind_noise_m_s / math.sqrt(n_eff)
    assert wind.std() == pytest.approx(p.wind_noise_m_s, rel=0.2)
    assert not x[:, 3].any()                         # rain_rate_per_h = 0: no random rain
    assert wind.max() < p.high_wind_limit_m_s         # a default night never closes


def test_weather_events_and_overrides_change_the_series():
    """A scripted gust raises the wind for its duration only; a rain rate override makes rain."""
    p = PARAMS.weather
    w = WeatherModel(p, 1, [WeatherEvent(10.0, "gust", 5.0, 25.0)])
    seen = {}
    for t in (9, 10, 14, 15):
        w.advance_to(t * 1_000_000)
        seen[t] = w.wind_m_s
    assert seen[10] == seen[14] == 25.0 and seen[9] < 25.0 and seen[15] < 25.0
    wet = load_parameters(overrides={"weather.rain_rate_per_h": 60.0}).weather
    w = WeatherModel(wet, 1)
    rain = []
    for k in range(3 * 3600):
        w.advance_to(k * 1_000_000)
        rain.append(w.rain)
    assert 0.05 < np.mean(rain) < 0.95


class _StationRig:
    """A weather station on a fake bus, its sensors driven by test-owned signals."""

    def __init__(self, **over):
        p = PARAMS.weather
        self.s = Scheduler()
        self.bus = FakeBus()
        self.wind, self.hum, self.temp, self.rain = 3.0, 50.0, 10.0, False
        kw = dict(sample_period_us=p.sample_period_us, temperature_min_c=p.temperature_min_c,
                  temperature_max_c=p.temperature_max_c, wind_full_scale_m_s=p.wind_full_scale_m_s,
                  high_wind_limit_m_s=p.high_wind_limit_m_s, high_wind_clear_m_s=p.high_wind_clear_m_s,
                  humidity_limit_pct=p.humidity_limit_pct, clear_hold_s=10.0)
        kw.update(over)
        span = p.temperature_max_c - p.temperature_min_c
        self.st = WeatherStation(
            self.s, self.bus, read_temperature_v=lambda: 5.0 * (self.temp - p.temperature_min_c) / span,
            read_humidity_v=lambda: 5.0 * self.hum / 100.0,
            read_wind_v=lambda: 5.0 * self.wind / p.wind_full_scale_m_s, read_rain=lambda: self.rain, **kw)
        self.st.start()
        nmt_start(self.st)

    def frames(self):
        return [_dbc().decode_message(m.arbitration_id, m.data) for m in self.bus.frames(P.weather_status_cob_id())]


def test_weather_station_flags_follow_the_documented_thresholds():
    """HIGH_WIND sets at the first sample at or above 15 m/s and clears only after the wind stayed
    below 12 m/s for the clear hold; RAIN sets on a wet sensor or humidity ≥ 90 %; the values
    in WEATHER_STATUS (decoded by cantools) are the sensors' within one ADC count."""
    r = _StationRig()
    r.s.run_until(3_000_000)
    f = r.frames()[-1]
    assert (f["high_wind"], f["rain"]) == (0, 0)
    assert f["wind_speed"] == pytest.approx(3.0, abs=0.05) and f["humidity"] == pytest.approx(50.0, abs=0.1)
    assert f["temperature"] == pytest.approx(10.0, abs=0.1)
    r.wind = 15.2
    r.s.run_until(4_000_000)
    assert r.frames()[-1]["high_wind"] == 1
    r.wind = 13.0                                # below the limit, above the clear level: held
    r.s.run_until(20_000_000)
    assert r.frames()[-1]["high_wind"] == 1
    r.wind = 5.0
    r.s.run_until(29_000_000)
    assert r.frames()[-1]["high_wind"] == 1      # 9 s below the clear level
    r.s.run_until(31_000_000)
    assert r.frames()[-1]["high_wind"] == 0
    r.hum = 90.5
    r.s.run_until(32_000_000)
    assert r.frames()[-1]["rain"] == 1
    r.hum = 60.0
    r.rain = True
    r.s.run_until(40_000_000)
    r.rain = False
    r.s.run_until(45_000_000)
    assert r.frames()[-1]["rain"] == 1
    r.s.run_until(51_000_000)
    assert r.frames()[-1]["rain"] == 0
    assert r.st.high_wind_events == 1 and r.st.rain_events == 1


# ------------------------------------------------------------------------------------------------
# display unit
# ------------------------------------------------------------------------------------------------

def test_display_formats_position_and_rates_and_shows_stale_inputs():
    """From POSITION and AXIS_STATUS frames the display shows HA in h:m:s, DEC in d:m:s, the axis
    rates (within 0.05″/s of the true 15″/s) and modes; an input silent for longer than the
    stale timeout becomes dashes and a DISPLAY_STATUS flag."""
    s, bus = Scheduler(), FakeBus()
    screens = []
    disp = DisplayUnit(s, bus, on_show=screens.append, refresh_period_us=250_000, stale_timeout_us=1_000_000)
    disp.start()
    nmt_start(disp)
    ha0, dec = 15.0 * 1.5, -12.5 - 30 / 60 - 15 / 3600          # HA 01:30:00, DEC -13:00:15

    def send(now):
        ha = ha0 + 15.0 / 3600 * now * 1e-6                          # sidereal-like 15″/s
        bus.inject(P.position_cob_id(P.NodeId.RA_READER), P.encode_position(0, 0, _pos_counts(ha)))
        if now < 3_000_000:
            bus.inject(P.position_cob_id(P.NodeId.DEC_READER), P.encode_position(0, 0, _pos_counts(dec)))
        bus.inject(P.axis_status_cob_id(P.NodeId.RA_AXIS), P.encode_axis_status(P.AxisMode.TRACK, 0, 0, 0))
        bus.inject(P.axis_status_cob_id(P.NodeId.DEC_AXIS), P.encode_axis_status(P.AxisMode.STOP, 0, 0, 0))

    s.call_every(10_000, send, start_us=0, priority=PRIO_PLANT)
    s.run_until(2_000_000)
    text = screens[-1]
    assert text.startswith("HA +01:30:02.0 DEC -13:00:15 ")       # 2 s at 15″/s = 2 s of time... of HA
    rate = float(text.split("dHA ")[1].split('"')[0])
    assert rate == pytest.approx(15.0, abs=0.05)
    assert text.endswith("RA TRACK DEC STOP")
    s.run_until(4_500_000)
    assert "DEC ---:--:--" in screens[-1] and "dDEC ------" in screens[-1]
    st = _dbc().decode_message(0x18C, bus.frames(P.display_status_cob_id())[-1].data)
    assert st["dec_position_stale"] == 1 and st["ra_position_stale"] == 0
    # sent at the 16th refresh (4.0 s): frames every 10 ms from 0 to 4.0 s (RA position and both
    # AXIS_STATUS: 401 each), the DEC position until 3.0 s (300)
    assert st["refreshes"] == 16 and st["frames_received"] == 3 * 401 + 300
    assert format_hms(-0.5) == "-00:30:00.0" and format_dms(29.366667) == "+29:22:00"


# ------------------------------------------------------------------------------------------------
# the host honours the weather (whole network)
# ------------------------------------------------------------------------------------------------

ROOM_NETWORK = ("ra-axis", "dec-axis", "ra-reader", "dec-reader", "focus", "display", "dome", "weather")


def test_host_stops_refuses_and_parks_on_high_wind_and_logs_the_clear(tmp_path):
    """A gust above the limit at 3 s: the host logs weather-unsafe, sends STOP_ALL and DOME PARK,
    the RA axis stops, a TRACK segment during the gust is refused (commands.log, errors.log),
    the dome parks; after the wind stayed low for the clear hold the host logs weather-clear and
    the next TRACK is obeyed. display.log has one line per 250 ms refresh."""
    from host.runner import run_scenario
    from host.scenario import parse_scenario
    sc = parse_scenario(f"""
name: weather-stop
seed: 5
plant: {{overrides: {{weather.clear_hold_s: 2}}}}
weather:
  events: [{{at_s: 3.0, kind: gust, duration_s: 2.0, wind_m_s: 20}}]
segments:
  - {{name: go, axis: ra, mode: set, duration_s: 3.5, dome: follow}}
  - {{name: during, axis: ra, mode: track, duration_s: 3}}
  - {{name: wait, axis: ra, mode: stop, duration_s: 2.5}}
  - {{name: after, axis: ra, mode: track, duration_s: 1.5}}
""", str(tmp_path / "s.yaml"))
    res = run_scenario(sc, tmp_path, boards=ROOM_NETWORK, plots=False)
    rep = res.report
    errors = (tmp_path / "errors.log").read_text().splitlines()
    unsafe = [ln for ln in errors if " weather-unsafe " in ln]
    clear = [ln for ln in errors if " weather-clear " in ln]
    assert len(unsafe) == 1 and len(clear) == 1
    t_unsafe, t_clear = float(unsafe[0].split()[0]), float(clear[0].split()[0])
    assert 3.0 <= t_unsafe <= 4.01                      # the first 1 s sample in the gust
    assert t_clear >= 5.0 + 2.0                         # gust over + clear hold
    commands = (tmp_path / "commands.log").read_text().splitlines()
    assert any(ln.split()[1:3] == ["all", "STOP_ALL"] and float(ln.split()[0]) == t_unsafe for ln in commands)
    assert any(ln.split()[1:3] == ["dome", "PARK"] for ln in commands)
    refused = [ln for ln in commands if " REFUSED " in ln]
    assert len(refused) == 1 and "TRACK" in refused[0] and "high_wind" in refused[0]
    assert any(" command-refused " in ln for ln in errors)
    segs = {s["name"]: s for s in rep["segments"]}
    assert segs["during"]["setpoint_arcsec_s"] == 0.0 and segs["after"]["setpoint_arcsec_s"] == 15.0
    assert rep["weather_stops"] == 1 and rep["host_refused_commands"] == 1
    # the RA axis was in STOP (from the AXIS_STATUS the host decoded) after the unsafe time
    status = (tmp_path / "status.log").read_text().splitlines()
    modes = [(float(ln.split()[0]), ln.split()[-1]) for ln in status if " ra-axis mode " in ln]
    assert any(t > t_unsafe and m == "STOP" for t, m in modes)
    assert modes[-1][1] == "TRACK"
    dome_rows = [ln for ln in status if " dome dome " in ln]
    assert any("mode=PARK" in ln for ln in dome_rows)
    # one display line per refresh (250 ms) for the run's simulated time
    lines = [ln for ln in (tmp_path / "display.log").read_text().splitlines() if not ln.startswith("#")]
    assert len(lines) == int(rep["simulated_s"] / 0.25)
    assert rep["boards"]["weather"]["high_wind_events"] == 1
    # the dome plant (plant/dome.py, the truth) never turned faster than the firmware's limit
    assert 0 < rep["room"]["dome"]["peak_rate_deg_s"] <= PARAMS.dome.max_rate_deg_s + 1e-9


def test_a_silent_weather_station_is_unsafe_weather(tmp_path):
    """The weather station loses power at 3 s (fault ``remove_board``). Its last WEATHER_STATUS
    was at most 1 s before; 2.5 s (``WEATHER_TIMEOUT_US``) after it the host logs
    ``weather-silent``, sends STOP_ALL and DOME PARK, and refuses the next TRACK: with no weather
    data the weather is unknown, and unknown is unsafe. Nothing clears it while the station is off."""
    from host.client import HostClient
    from host.runner import run_scenario
    from host.scenario import parse_scenario
    sc = parse_scenario("""
name: weather-silent
seed: 5
network: [ra-axis, dec-axis, ra-reader, dec-reader, focus, display, dome, weather, gateway]
faults: [{at_s: 3.0, kind: remove_board, board: weather}]
segments:
  - {name: go, axis: ra, mode: set, duration_s: 6.5, dome: follow}
  - {name: during, axis: ra, mode: track, duration_s: 2}
""", str(tmp_path / "s.yaml"))
    res = run_scenario(sc, tmp_path, plots=False)
    errors = (tmp_path / "errors.log").read_text().splitlines()
    silent = [ln for ln in errors if " weather-silent " in ln]
    assert len(silent) == 1, errors
    t_silent = float(silent[0].split()[0])
    timeout_s = HostClient.WEATHER_TIMEOUT_US / 1e6
    # last status in [2, 3] s, then timeout, then at most one 0.1 s check late
    assert 2.0 + timeout_s < t_silent <= 3.0 + timeout_s + 0.1 + 1e-6
    assert not any(" weather-clear " in ln for ln in errors)
    commands = (tmp_path / "commands.log").read_text().splitlines()
    assert any(ln.split()[1:3] == ["all", "STOP_ALL"] and float(ln.split()[0]) == t_silent for ln in commands)
    assert any(ln.split()[1:3] == ["dome", "PARK"] and float(ln.split()[0]) == t_silent for ln in commands)
    refused = [ln for ln in commands if " REFUSED " in ln]
    assert len(refused) == 1 and "TRACK" in refused[0]
    assert res.report["weather_stops"] == 1
    segs = {s["name"]: s for s in res.report["segments"]}
    assert segs["during"]["setpoint_arcsec_s"] == 0.0


def test_dome_segment_without_a_dome_fails_before_running(tmp_path):
    """A segment commanding the dome on a network without one is refused before power-on."""
    from host.runner import run_scenario
    from host.scenario import ScenarioError, parse_scenario
    sc = parse_scenario("name: x\nsegments:\n  - {name: a, mode: stop, duration_s: 1, dome: park}\n",
                        str(tmp_path / "s.yaml"))
    with pytest.raises(ScenarioError, match=r"segments\[0\]\.dome"):
        run_scenario(sc, None)


def test_a_fault_on_a_board_not_in_the_network_fails_before_running(tmp_path):
    """A fault aimed at a room node that the default network does not build is refused when the
    scenario loads, naming the key."""
    from host.scenario import ScenarioError, parse_scenario
    with pytest.raises(ScenarioError, match=r"faults\[0\]\.board.*not on the network 'basic'"):
        parse_scenario("name: x\nfaults:\n  - {at_s: 0.5, kind: board_reset, board: dome}\n"
                       "segments:\n  - {name: a, mode: stop, duration_s: 1}\n", str(tmp_path / "s.yaml"))


def test_dome_objects_are_written_and_range_checked_over_sdo(tmp_path):
    """An SDO download of the park azimuth (0x2400:4) and deadband (0x2400:3) reaches the dome
    firmware; a park azimuth beyond 359.99° is aborted by the EDS range and changes nothing;
    the drive limits are read-only."""
    import canopen
    from canopen_sim import PumpedNetwork
    from host.network import build_network
    from host.scenario import parse_scenario
    sc = parse_scenario("name: r\nsegments:\n  - {name: a, mode: stop, duration_s: 1}\n", str(tmp_path / "s.yaml"))
    tel = build_network(sc, boards=("ra-axis", "dec-axis", "dome"))
    try:
        master = PumpedNetwork(tel.scheduler, tel.network)
        tel.scheduler.run_until(20_000)
        node = master.add_remote("dome", int(P.NodeId.DOME))
        dome = tel.boards["dome"]
        node.sdo[0x2400][4].raw = 9000
        node.sdo[0x2400][3].raw = 150
        assert (dome.park_azimuth_deg, dome.deadband_deg) == (90.0, 1.5)
        with pytest.raises(canopen.SdoAbortedError):
            node.sdo[0x2400][4].raw = 36000
        with pytest.raises(canopen.SdoAbortedError):
            node.sdo[0x2400][1].raw = 5000
        assert dome.park_azimuth_deg == 90.0 and dome.max_rate_deg_s == PARAMS.dome.max_rate_deg_s
        assert node.sdo[0x2400][5].raw == round(PARAMS.site.latitude_deg * 1e6)
    finally:
        tel.close()
