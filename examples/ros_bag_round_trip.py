"""A ROS 2 bag round trip: a planner's path in, a tracked run out, read back.

Shows, with the pure-Python ``rosbags`` package (``pip install 'holonomic-mpc[ros]'``; no
ROS install needed):

1. a bag holding one ``nav_msgs/Path`` on ``/plan``, as ``ros2 bag record /plan`` would
   save a planner's output (written here with ``rosbags``);
2. :func:`trajectories.read_bag_reference` turning that path into a reference timed for
   the robot (time-optimal within its wheel limits);
3. :func:`mpc.sim.simulate` tracking it on a robot with motor lag, delay, noise and slip,
   and :func:`mpc.sim.write_bag` writing the run as an MCAP bag that Foxglove or RViz
   replays (``/odom``, ``/tf``, ``/mpc/cmd_vel``, the wheels' commands and limits...);
4. reading the run's bag back with ``rosbags`` alone: the ``/odom`` poses must be the
   simulated poses, and the wheel commands must stay within the limits the bag records.

Run::

    python examples/ros_bag_round_trip.py                  # the path and 1 s after it
    python examples/ros_bag_round_trip.py --duration 5 --out figures/

Writes ``plan_bag/`` and ``run_bag/`` in a temporary folder (``--bags DIR`` keeps them),
the figure ``ros_bag_round_trip.png`` in ``--out``; prints the topics written, the path's
length in time, the tracking error and how closely the bag's odometry matches the run.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import mpc
from mpc.robots import preset
from mpc.sim import simulate, write_bag
from trajectories import read_bag_reference

SKIP = 0.5  # [s] start-up left out of the metrics


def plan_poses(count: int = 40) -> np.ndarray:
    """A planner's path: an S through (0, 0) -> (3, 0), the heading turning 1.5 rad."""
    s = np.linspace(0.0, 1.0, count)
    return np.stack([3.0 * s, 0.6 * np.sin(2 * np.pi * s), 1.5 * s], axis=1)


def write_plan_bag(folder: Path, poses: np.ndarray) -> Path:
    """A bag with one ``nav_msgs/Path`` message on ``/plan`` (frame ``map``)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    header = t["std_msgs/msg/Header"](
        stamp=t["builtin_interfaces/msg/Time"](sec=1_700_000_000, nanosec=0), frame_id="map")
    stamped = [t["geometry_msgs/msg/PoseStamped"](header=header, pose=t["geometry_msgs/msg/Pose"](
        position=t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
        orientation=t["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))))
        for x, y, yaw in poses]
    message = t["nav_msgs/msg/Path"](header=header, poses=stamped)
    bag = folder / "plan_bag"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/plan", message.__msgtype__, typestore=store)
        writer.write(connection, 1_700_000_000 * 10**9,
                     store.serialize_cdr(message, message.__msgtype__))
    return bag


def read_run_bag(bag: Path) -> dict[str, np.ndarray]:
    """The run's ``/odom`` poses (x, y, yaw), its wheel commands and limits [rad/s] and
    their times [s], read with ``rosbags`` alone."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    series: dict[str, list[np.ndarray]] = {"odom": [], "command": [], "limit": [], "time": []}
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        for connection, stamp, raw in reader.messages():
            message: Any = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/odom":
                q = message.pose.pose.orientation
                yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))
                p = message.pose.pose.position
                series["odom"].append(np.array([p.x, p.y, yaw]))
                series["time"].append(np.array(stamp * 1e-9))
            elif connection.topic == "/mpc/wheel_command":
                series["command"].append(np.array(message.velocity))
            elif connection.topic == "/mpc/wheel_limit":
                series["limit"].append(np.array(message.velocity))
    return {key: np.array(values) for key, values in series.items()}


def run(duration: float | None, out: Path, bags: Path) -> dict[str, float]:
    """The round trip; writes ``out/ros_bag_round_trip.png``; returns the numbers printed."""
    robot = preset("mecanum")
    poses = plan_poses()
    reference = read_bag_reference(write_plan_bag(bags, poses), "/plan", robot=robot)
    end = reference.end_time                   # [s] a path's timing ends (at rest)
    assert end is not None
    controller = mpc.Controller(robot, reference, horizon=20, dt=0.05, delay_ticks=1)
    seconds = end + 1.0 if duration is None else duration
    result = simulate(controller, duration=seconds, plant="realistic", seed=3)
    topics = write_bag(result, bags / "run_bag")
    back = read_run_bag(bags / "run_bag")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (path_axes, wheel_axes) = plt.subplots(1, 2, figsize=(12, 4.8))
    dense = reference.sample(np.linspace(0.0, end, 400)).pose
    path_axes.plot(dense[:, 0], dense[:, 1], "--", color="grey", label="reference (timed)")
    path_axes.plot(poses[:, 0], poses[:, 1], "o", ms=3, color="k", label="/plan poses")
    path_axes.plot(back["odom"][:, 0], back["odom"][:, 1], color="C0",
                   label="/odom read back from run_bag")
    path_axes.set(xlabel="x [m]", ylabel="y [m]", title="(a) path in, run out", aspect="equal")
    path_axes.legend(loc="lower left", fontsize=8)
    for wheel, name in enumerate(("FL", "FR", "RL", "RR")):
        wheel_axes.plot(back["time"], back["command"][:, wheel], lw=1, label=name)
    wheel_axes.plot(back["time"], back["limit"][:, 0], "k--", lw=1, label="+-limit")
    wheel_axes.plot(back["time"], -back["limit"][:, 0], "k--", lw=1)
    top = 1.4 * float(back["limit"].max())
    wheel_axes.set(xlabel="time [s]", ylabel="wheel command [rad/s]", ylim=(-top, top),
                   title="(b) /mpc/wheel_command and /mpc/wheel_limit read back")
    wheel_axes.legend(loc="upper right", fontsize=8, ncols=5)
    figure.tight_layout()
    out.mkdir(parents=True, exist_ok=True)
    figure.savefig(out / "ros_bag_round_trip.png", dpi=100)
    plt.close(figure)

    metrics = result.metrics(skip=min(SKIP, seconds / 2))
    return {"topics": len(topics), "end_time": end,
            "rms_position_error": metrics["rms_position_error"],
            "odom_mismatch": float(np.abs(back["odom"][:, :2] - result.pose[:, :2]).max()),
            "odom_messages": len(back["odom"]), "ticks": len(result.time),
            "peak_command_ratio": float((np.abs(back["command"]) / back["limit"]).max())}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=None,
                        help="seconds to run (default: the timed path + 1 s)")
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for the figure")
    parser.add_argument("--bags", type=Path, default=None,
                        help="folder for plan_bag/ and run_bag/ (default: a temporary one)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        bags = args.bags or Path(scratch)
        bags.mkdir(parents=True, exist_ok=True)
        numbers = run(args.duration, args.out, bags)
    print(f"path timed for the robot: {numbers['end_time']:.2f} s")
    print(f"run bag: {numbers['topics']} topics, {numbers['odom_messages']} /odom messages "
          f"for {numbers['ticks']} ticks")
    print(f"rms position error: {numbers['rms_position_error'] * 1e3:.1f} mm")
    print(f"/odom against the run: {numbers['odom_mismatch']:.1e} m")
    print(f"peak wheel command: {numbers['peak_command_ratio']:.2f} of the limit")
    print(f"figure: {args.out / 'ros_bag_round_trip.png'}")


if __name__ == "__main__":
    main()
