"""Weather station firmware, node 0x0E (issue 12; paper §5.2: weather station control
"implemented and tested in the lab on RS232 ports"; no hardware is given, so the sensors and
thresholds are assumed: plant/parameters.yaml ``weather``).

Peripherals: a 10-bit ADC with three analog transmitters (temperature, relative humidity,
anemometer; 0–5 V, transfer functions from the parameter file), one digital input (the rain
sensor's contact), CAN.

Every ``sample_period_us`` (1 s) the timer ISR samples the four inputs, converts them, updates
the flags and queues ``WEATHER_STATUS`` (TPDO1, 0x18E):

* **HIGH_WIND** sets at once when the wind ≥ ``high_wind_limit_m_s`` (15 m/s); it clears at the
  first sample at which the samples have been below ``high_wind_clear_m_s`` (12 m/s) for
  ``clear_hold_s`` (60 s), counted from the first such sample.
* **RAIN** sets at once when the rain sensor is wet or the humidity ≥ ``humidity_limit_pct``
  (90 %); it clears when the samples have been dry and below that humidity for ``clear_hold_s``.

The station only reports; the host decides (host/client.py: stop, refuse, park the dome). It
sends no EMCY for the weather (weather is not a fault of the station).

Not emulated: sensor faults, heating of the rain sensor, averaging of the wind over gusts (each
1 s sample counts), RS232 telemetry of the station.
"""

from __future__ import annotations

from typing import Callable, Final, Optional

import can

from boards.firmware_base import Board
from boards.peripherals import Adc, DigitalInput, Timer
from bus import protocol as proto
from bus.scheduler import PRIO_ISR, Scheduler
from mypy_extensions import mypyc_attr

__all__ = ["WeatherStation"]

_VREF_V: Final = 5.0


@mypyc_attr(allow_interpreted_subclasses=True)   # compiled (bus/_native.py); may be subclassed
class WeatherStation(Board):
    """Weather station firmware.

    Parameters
    ----------
    scheduler, bus, name, serial_port
        As :class:`boards.firmware_base.Board` (no telemetry: ``serial_port`` is ignored).
    node_id : int
        0x0E.
    read_temperature_v, read_humidity_v, read_wind_v : callable() -> float
        Ports: the transmitters' outputs, V (0–5).
    read_rain : callable() -> bool
        Port: the rain sensor's contact (True = wet).
    sample_period_us : int
        Sampling and WEATHER_STATUS period, µs (1 s).
    temperature_min_c, temperature_max_c : float
        Temperature at 0 V and 5 V, °C.
    wind_full_scale_m_s : float
        Wind at 5 V, m/s.
    high_wind_limit_m_s, high_wind_clear_m_s, humidity_limit_pct, clear_hold_s : float
        Thresholds (see the module docstring).

    Raises
    ------
    ValueError
        The clear level above the limit, or a non-positive span.
    """

    DEVICE_TYPE = int(proto.DeviceType.WEATHER)
    KIND = "weather"
    CANOPEN_KIND = "weather"

    def __init__(self, scheduler: Scheduler, bus: can.BusABC, node_id: int = int(proto.NodeId.WEATHER), *,
                 read_temperature_v: Callable[[], float], read_humidity_v: Callable[[], float],
                 read_wind_v: Callable[[], float], read_rain: Callable[[], bool],
                 sample_period_us: int, temperature_min_c: float, temperature_max_c: float,
                 wind_full_scale_m_s: float, high_wind_limit_m_s: float, high_wind_clear_m_s: float,
                 humidity_limit_pct: float, clear_hold_s: float,
                 name: Optional[str] = None, serial_port=None) -> None:
        if not high_wind_clear_m_s <= high_wind_limit_m_s:
            raise ValueError("high_wind_clear_m_s must not exceed high_wind_limit_m_s")
        if not temperature_max_c > temperature_min_c or not wind_full_scale_m_s > 0:
            raise ValueError("sensor spans must be positive")
        super().__init__(scheduler, bus, node_id, name=name, background_period_us=sample_period_us)
        self.sample_period_us = int(sample_period_us)
        self.temperature_min_c = float(temperature_min_c)
        self.temperature_span_c = float(temperature_max_c) - self.temperature_min_c
        self.wind_full_scale_m_s = float(wind_full_scale_m_s)
        self.high_wind_limit_m_s = float(high_wind_limit_m_s)
        self.high_wind_clear_m_s = float(high_wind_clear_m_s)
        self.humidity_limit_pct = float(humidity_limit_pct)
        self.clear_hold_us = int(round(float(clear_hold_s) * 1e6))
        self.adc = Adc({"temperature": read_temperature_v, "humidity": read_humidity_v, "wind": read_wind_v},
                       bits=10, vref_v=_VREF_V)
        self.rain_input = DigitalInput(read_rain)
        self.timer = self.add_timer(Timer(scheduler, self.sample_period_us, self.isr_sample,
                                          priority=PRIO_ISR, owner=f"{self.name}/isr"))
        self._init_weather_state()

    def _peripherals(self) -> list:
        return [self.adc, self.rain_input]

    def _init_state(self) -> None:
        super()._init_state()
        if hasattr(self, "adc"):
            self._init_weather_state()

    def _init_weather_state(self) -> None:
        self.temperature_c = 0.0
        self.humidity_pct = 0.0
        self.wind_m_s = 0.0
        self.rain_wet = False
        self.flags = 0
        self._wind_low_since_us: Optional[int] = None   # first sample of the present run below the clear level
        self._rain_dry_since_us: Optional[int] = None   # first sample of the present run dry and not humid
        self.samples = 0
        self.high_wind_events = 0
        self.rain_events = 0

    def report_counters(self) -> dict:
        """Samples taken and how often each flag was raised (report board row)."""
        return {"samples": self.samples, "high_wind_events": self.high_wind_events,
                "rain_events": self.rain_events}

    def _volts(self, name: str) -> float:
        return (self.adc.sample(name) + 0.5) * self.adc.lsb_v      # mid-point of the count

    def isr_sample(self, now_us: int) -> None:
        """Sample the sensors, update the flags, queue WEATHER_STATUS."""
        self.samples += 1
        self.temperature_c = self.temperature_min_c + self.temperature_span_c * self._volts("temperature") / _VREF_V
        self.humidity_pct = 100.0 * self._volts("humidity") / _VREF_V
        self.wind_m_s = self.wind_full_scale_m_s * self._volts("wind") / _VREF_V
        self.rain_wet = self.rain_input.read()
        f = self.flags
        wind_flag, rain_flag = int(proto.WeatherFlags.HIGH_WIND), int(proto.WeatherFlags.RAIN)
        if self.wind_m_s >= self.high_wind_clear_m_s:
            self._wind_low_since_us = None
        elif self._wind_low_since_us is None:
            self._wind_low_since_us = now_us
        if self.wind_m_s >= self.high_wind_limit_m_s:
            if not f & wind_flag:
                self.high_wind_events += 1
            f |= wind_flag
        elif (f & wind_flag and self._wind_low_since_us is not None
              and now_us - self._wind_low_since_us >= self.clear_hold_us):
            f &= ~wind_flag
        if self.rain_wet or self.humidity_pct >= self.humidity_limit_pct:
            self._rain_dry_since_us = None
            if not f & rain_flag:
                self.rain_events += 1
            f |= rain_flag
        else:
            if self._rain_dry_since_us is None:
                self._rain_dry_since_us = now_us
            if f & rain_flag and now_us - self._rain_dry_since_us >= self.clear_hold_us:
                f &= ~rain_flag
        self.flags = f
        self.queue(proto.weather_status_cob_id(self.node_id), proto.encode_weather_status(
            f, int(round(self.temperature_c * 100)), int(round(self.humidity_pct * 100)),
            int(round(self.wind_m_s * 100))))

    # ------------------------------------------------------------------ CANopen objects (SDO)
    def od_read(self, index: int, subindex: int):
        """0x2500 the thresholds."""
        if index == 0x2500:
            return {1: int(round(self.high_wind_limit_m_s * 100)), 2: int(round(self.high_wind_clear_m_s * 100)),
                    3: self.clear_hold_us // 1_000_000, 4: int(round(self.humidity_limit_pct * 100))}.get(subindex)
        return super().od_read(index, subindex)
