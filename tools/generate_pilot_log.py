#!/usr/bin/env python3
"""Writes a pilot-style pose-command log as CSV (t_s, x_m, y_m, z_m, qx, qy, qz, qw), the kind a real
transmitter produces and `iapsim replay LOG.csv --topic ...` plays (issue 23):

    python3 tools/generate_pilot_log.py --seed 2 > configs/logs/pilot_steps.csv

A radio sends its stick state at a fixed rate (50 Hz) on the wall clock (epoch stamps, here from
1700000000 s), in NED. The values hold between the pilot's inputs, and the inputs are abrupt:
- position moves at a constant stick speed, started and stopped at once (a velocity step), horizontally or
  vertically;
- attitude switched by a channel (as in the seed's three-square flight, section VI-B): roll or pitch to
  +-8 deg and back, yaw by +-20 deg, each a step from one sample to the next;
- holds in between.
The sequence is drawn from `random.Random(seed)` (Python's Mersenne Twister: the same seed gives the same
bytes on every platform), so a log is reproducible from its seed. The log starts at rest at `start`, where
the scenario's vehicle starts, and ends with a hold.
"""
import argparse
import math
import random

RATE_HZ = 50.0
EPOCH_S = 1700000000.0


def quaternion_zyx(roll, pitch, yaw):
    """(qx, qy, qz, qw) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def events(rng, duration_s, max_speed, tilt_deg, yaw_step_deg):
    """The pilot's inputs as (start time, kind, value) over the flight, 1.5 to 4 s apart."""
    t = 2.0
    out = []
    while t < duration_s - 6.0:
        kind = rng.choice(["move", "move", "tilt", "yaw", "hold"])
        if kind == "move":
            axis = rng.choice([0, 1, 2]) if rng.random() < 0.8 else 2
            speed = rng.uniform(0.5, 1.0) * max_speed * (0.5 if axis == 2 else 1.0)
            out.append((t, "move", (axis, speed * rng.choice([-1, 1]), rng.uniform(1.0, 3.0))))
        elif kind == "tilt":
            out.append((t, "tilt", (rng.choice([0, 1]), rng.choice([-1, 1]) * tilt_deg, rng.uniform(1.5, 3.0))))
        elif kind == "yaw":
            out.append((t, "yaw", rng.choice([-1, 1]) * yaw_step_deg))
        t += rng.uniform(1.5, 4.0)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--duration", type=float, default=60.0, help="s")
    parser.add_argument("--start", type=float, nargs=3, default=[0.0, 0.0, -2.0], help="m, NED")
    parser.add_argument("--max-speed", type=float, default=0.4, help="horizontal stick speed, m/s")
    parser.add_argument("--box", type=float, default=1.5, help="half-width the moves stay inside, m")
    parser.add_argument("--tilt", type=float, default=8.0, help="roll / pitch switch, deg")
    parser.add_argument("--yaw-step", type=float, default=20.0, help="deg")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    plan = events(rng, args.duration, args.max_speed, args.tilt, args.yaw_step)

    position = list(args.start)
    rpy_deg = [0.0, 0.0, 0.0]
    velocity = [0.0, 0.0, 0.0]
    move_end = -1.0
    tilt_end = [-1.0, -1.0]
    samples = int(round(args.duration * RATE_HZ))
    print("t_s,x_m,y_m,z_m,qx,qy,qz,qw")
    for k in range(samples + 1):
        t = k / RATE_HZ
        while plan and plan[0][0] <= t:
            _, kind, value = plan.pop(0)
            if kind == "move":
                axis, speed, length_s = value
                # stay inside the box (and 0.5 m clear of the ground below the start): reverse if it would leave
                low, high = args.start[axis] - args.box, args.start[axis] + (0.5 if axis == 2 else args.box)
                if not low <= position[axis] + speed * length_s <= high:
                    speed = -speed
                velocity = [0.0, 0.0, 0.0]
                velocity[axis] = speed
                move_end = t + length_s
            elif kind == "tilt":
                axis, angle, length_s = value
                rpy_deg[axis] = angle
                tilt_end[axis] = t + length_s
            elif kind == "yaw":
                rpy_deg[2] += value if abs(rpy_deg[2] + value) <= 45.0 else -value
        if t >= move_end:
            velocity = [0.0, 0.0, 0.0]
        for axis in (0, 1):
            if t >= tilt_end[axis]:
                rpy_deg[axis] = 0.0
        q = quaternion_zyx(*[math.radians(a) for a in rpy_deg])
        print("%.2f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f" % ((EPOCH_S + t,) + tuple(position) + q))
        position = [p + v / RATE_HZ for p, v in zip(position, velocity)]


if __name__ == "__main__":
    main()
