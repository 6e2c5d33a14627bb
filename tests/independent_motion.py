"""A copter's stop-to-stop time over a straight run, by stepping its motion (no closed form): from rest
the acceleration rises at the jerk limit up to the acceleration limit and falls again at the jerk limit so
that the speed levels off at the peak; the braking is the same backwards. It shares no code with
aerosurvey's flight-time model."""

from __future__ import annotations

import bisect
import math

DT = 2e-4  # seconds per step


def _speed_up(peak: float, accel: float, jerk: float) -> tuple[float, float]:
    """Seconds and metres from rest to `peak` m/s: the acceleration ramped up at `jerk` (held at `accel`), and
    ramped down at `jerk` from the moment the speed it would still gain, acc²/(2·jerk), reaches the peak.
    jerk = 0: no jerk limit (the acceleration jumps)."""
    ts, xs = _speed_up_track(peak, accel, jerk)
    return ts[-1], xs[-1]


def stop_to_stop_time(d: float, speed: float, accel: float, jerk: float) -> float:
    """Seconds from rest to rest over `d` metres with top speed `speed`: cruising between the speed-up and the
    braking, or, too short for that, turning back at the peak speed whose speed-up covers d/2 (bisection)."""
    t, x = _speed_up(speed, accel, jerk)
    if 2.0 * x <= d:
        return 2.0 * t + (d - 2.0 * x) / speed
    return 2.0 * _speed_up(_peak(d, speed, accel, jerk), accel, jerk)[0]


def _peak(d: float, speed: float, accel: float, jerk: float) -> float:
    """The peak speed of a stop-to-stop run over `d` metres too short to cruise at `speed`: the one whose speed-up
    covers d/2 (bisection)."""
    lo, hi = 0.0, speed
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if 2.0 * _speed_up(mid, accel, jerk)[1] < d:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _speed_change(d: float, speed: float, accel: float, jerk: float) -> float:
    """Seconds a stop-to-stop run over `d` metres takes to reach its peak speed (and to brake from it): the
    speed-up of `stop_to_stop_time`'s motion, to the top speed or to the peak speed of a run too short to cruise."""
    t, x = _speed_up(speed, accel, jerk)
    if 2.0 * x <= d:
        return t
    return 0.5 * stop_to_stop_time(d, speed, accel, jerk)


def flown_through_time(legs: list[float], speed: float, accel: float, jerk: float) -> float:
    """Seconds from rest to rest along waypoints `legs` metres apart, flown through as ArduCopter's
    S-curves do (AP_Math/SCurve.cpp, SCurve::advance_target_along_track): every leg is its own
    stop-to-stop motion, and the next leg starts once this one brakes and has no more time left than
    the next one's speed-up takes (the two motions add up meanwhile). On a timeline: each leg's start,
    its braking's start and its end."""
    start = 0.0
    end = 0.0
    for i, d in enumerate(legs):
        whole = stop_to_stop_time(d, speed, accel, jerk)
        if i:
            # the previous leg brakes over its last `brake` seconds; this one starts when the time left of it
            # is no more than this one's speed-up
            brake = _speed_change(legs[i - 1], speed, accel, jerk)
            start = end - min(brake, _speed_change(d, speed, accel, jerk))
        end = start + whole
    return end


def _speed_up_track(peak: float, accel: float, jerk: float) -> tuple[list[float], list[float]]:
    """`_speed_up`'s motion step by step: the times and the distances covered from rest up to `peak` m/s."""
    ts, xs = [0.0], [0.0]
    t = x = v = acc = 0.0
    falling = False
    while v < peak:
        if jerk <= 0.0:
            acc = accel
        elif falling or v + acc * acc / (2.0 * jerk) >= peak:
            falling = True
            acc = max(acc - jerk * DT, 0.0)
            if acc == 0.0:
                break
        else:
            acc = min(acc + jerk * DT, accel)
        step = min(DT, (peak - v) / acc) if acc > 0 else DT
        x += (v + 0.5 * acc * step) * step
        v += acc * step
        t += step
        ts.append(t)
        xs.append(x)
    return ts, xs


class _Leg:
    """One leg's stop-to-stop motion over `d` metres (as `stop_to_stop_time`'s): where it is `t` s after its start."""

    def __init__(self, d: float, speed: float, accel: float, jerk: float):
        t, x = _speed_up(speed, accel, jerk)
        peak = speed if 2.0 * x <= d else _peak(d, speed, accel, jerk)  # too short to cruise: a lower peak
        self.ts, self.xs = _speed_up_track(peak, accel, jerk)
        self.d, self.peak, self.up = d, peak, self.ts[-1]
        self.whole = 2.0 * self.up + max(d - 2.0 * self.xs[-1], 0.0) / peak

    def _from_rest(self, t: float) -> float:
        t = min(max(t, 0.0), self.up)
        i = bisect.bisect_right(self.ts, t) - 1
        if i + 1 >= len(self.ts):
            return self.xs[-1]
        f = (t - self.ts[i]) / (self.ts[i + 1] - self.ts[i])
        return self.xs[i] + f * (self.xs[i + 1] - self.xs[i])

    def at(self, t: float) -> float:
        if t >= self.whole - self.up:
            return self.d - self._from_rest(self.whole - t)
        if t <= self.up:
            return self._from_rest(t)
        return self.xs[-1] + (t - self.up) * self.peak


def cornered_time(legs: list[float], turns: list[float], speed: float, accel: float, jerk: float,
                  radius: float) -> float:
    """Seconds from rest to rest along waypoints `legs` metres apart, turning `turns[i]` degrees after leg i,
    flown as ArduCopter 4.x flies a mission's corners (AP_Math/SCurve.cpp, advance_target_along_track): every
    leg is its own stop-to-stop motion; once a leg brakes and has no more time left than the next one's
    speed-up, the next starts at the first moment (stepped in time) at which the two motions added together
    would lie within `radius` of the corner half-way through their overlap."""
    start = 0.0
    end = 0.0
    prev: _Leg | None = None
    for i, d in enumerate(legs):
        leg = _Leg(d, speed, accel, jerk)
        if prev is None:
            start = 0.0
        else:
            turn = math.radians(turns[i - 1])
            # the two directions: the leg before along +x, this one turned by `turn`
            ux, uy = math.cos(turn), math.sin(turn)
            # not before the leg before brakes, nor while more of it is left than this one's speed-up
            s = end - min(prev.up, leg.up)
            while s < end:
                mid = 0.5 * (s + end)
                back = prev.d - prev.at(mid - start)  # the leg before's distance short of the corner
                on = leg.at(mid - s)  # this one's from it
                if math.hypot(on * ux - back, on * uy) < radius:
                    break
                s += 1e-3
            start = min(s, end)
        end = start + leg.whole
        prev = leg
    return end
