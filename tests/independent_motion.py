"""A copter's stop-to-stop time over a straight run, by stepping its motion (no closed form): from rest
the acceleration rises at the jerk limit up to the acceleration limit and falls again at the jerk limit so
that the speed levels off at the peak; the braking is the same backwards. It shares no code with
aerosurvey's flight-time model."""

from __future__ import annotations

DT = 2e-4  # seconds per step


def _speed_up(peak: float, accel: float, jerk: float) -> tuple[float, float]:
    """Seconds and metres from rest to `peak` m/s: the acceleration ramped up at `jerk` (held at `accel`), and
    ramped down at `jerk` from the moment the speed it would still gain, acc²/(2·jerk), reaches the peak.
    jerk = 0: no jerk limit (the acceleration jumps)."""
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
    return t, x


def stop_to_stop_time(d: float, speed: float, accel: float, jerk: float) -> float:
    """Seconds from rest to rest over `d` metres with top speed `speed`: cruising between the speed-up and the
    braking, or, too short for that, turning back at the peak speed whose speed-up covers d/2 (bisection)."""
    t, x = _speed_up(speed, accel, jerk)
    if 2.0 * x <= d:
        return 2.0 * t + (d - 2.0 * x) / speed
    lo, hi = 0.0, speed
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if 2.0 * _speed_up(mid, accel, jerk)[1] < d:
            lo = mid
        else:
            hi = mid
    return 2.0 * _speed_up(0.5 * (lo + hi), accel, jerk)[0]


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
