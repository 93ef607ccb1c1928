"""A team's own robot, end to end: its log, its camera, measured points, its camera file.

Two steps, each from a log dsp-record wrote (its camera metadata says what camera drew it)::

    python scripts/team_example.py convert source.mcap team.mcap [--pad 1280x1024
        --centre 640,512] [--mount-deg 90] [--map-origin -9,-6] [--epoch 1733068800]
        [--encoding bgr8|png] [--exact-cameras exact.yaml]
    python scripts/team_example.py measure source.mcap points.csv [--points 40] [--seed 1]
        (the same --pad, --centre and --mount-deg)

``convert`` writes the log in a team's own layout: images on ``/{robot}/camera/image_raw``
as ``sensor_msgs/Image`` bgr8 (``--encoding png``: CompressedImage PNG, small), poses on
``/{robot}/amcl_pose`` as ``PoseWithCovarianceStamped`` in the frame ``map`` (whose origin
is the field point ``--map-origin``), stamps in Unix time (``--epoch``), the ball's true
position on ``/mocap/ball`` (a motion-capture system's topic: replay scores against it only
with ``--truth-topic``), and no dsp metadata, no /tf, no /ground_truth topics. Each image is
the recorded one moved into a ``--pad`` canvas so that its centre lands on ``--centre``
(pixels that fall outside are cut, the rest is black) and turned about it as a camera
mounted ``--mount-deg`` from the robot's forward would see it (image up shows that
robot-frame direction; 90: the robot's left), in one affine warp: an exact pixel copy when
the angle is a multiple of 90 deg and the centres are whole pixels. ``--exact-cameras``
writes the camera file that describes the converted camera exactly (the recorded model,
moved and turned) and names the field the source was recorded on (``field:``, which the
converted log no longer names), so the default replay fits the field lines as it does on
the source.

``measure`` plays a team measuring its camera: one robot alone at the field's centre, the
ball put at ``--points`` seeded places 0.5-8.5 m away in every direction, each image
rendered with the source log's camera, moved and turned as ``convert`` does, the ball
detected, and the place written down as a person would measure it: the ball's position off
by a tape's and a marker's error (1 cm per axis) and the robot's heading by 0.3 deg (its
placement). Out comes the CSV ``dsp-calibrate --from-measurements`` reads (u_px, v_px,
range_m, angle_deg).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
EPOCH_S = 1_733_068_800
TRUTH_TOPIC = "/mocap/ball"
IMAGE_TOPIC = "/{robot}/camera/image_raw"
POSE_TOPIC = "/{robot}/amcl_pose"
BALL_POSITION_SIGMA_M = 0.01
ROBOT_YAW_SIGMA_DEG = 0.3


def _pair(text: str, kind: type = float, sep: str = ",") -> tuple[Any, Any]:
    a, b = text.lower().split(sep)
    return kind(a), kind(b)


def warp_matrix(source_centre: tuple[float, float], centre: tuple[float, float],
                mount_deg: float) -> np.ndarray:
    """The 2 x 3 affine map of a recorded image's pixel to the team camera's: about the
    recorded centre, turned so a ball at robot bearing theta shows at image bearing
    theta - mount, then moved so the centre lands on ``centre``."""
    c, s = math.cos(math.radians(mount_deg)), math.sin(math.radians(mount_deg))
    if abs(c) < 1e-12:
        c = 0.0
    if abs(s) < 1e-12:
        s = 0.0
    cu, cv = source_centre
    return np.array([[c, -s, centre[0] - c * cu + s * cv],
                     [s, c, centre[1] - s * cu - c * cv]], dtype=np.float64)


def transform_image(img: np.ndarray, matrix: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The recorded image as the team camera sees it (black where nothing maps)."""
    return cv2.warpAffine(img, matrix, size, flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))


def _messages(path: Path) -> Iterator[tuple[str, Any, int]]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, msg in reader.iter_decoded_messages():
            yield channel.topic, msg, message.log_time


def _field(path: Path) -> str | None:
    """The name of the field the source log's dsp.scenario names (None: it has none)."""
    from mcap.reader import make_reader

    from dsp.metadata import ScenarioMetadata

    with path.open("rb") as f:
        for record in make_reader(f).iter_metadata():
            if record.name == "dsp.scenario":
                return ScenarioMetadata.from_metadata(dict(record.metadata)).field.name
    return None


def _camera(path: Path, robot: str = "robot1") -> dict[str, Any]:
    """The source log's camera model dict (its dsp.cameras metadata)."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        for record in make_reader(f).iter_metadata():
            if record.name == "dsp.cameras":
                return dict(json.loads(record.metadata[robot]))
    raise SystemExit(f"{path}: no dsp.cameras metadata (record it with dsp-record)")


class _Layout:
    """The team camera's geometry, from the command line and the source camera."""

    def __init__(self, args: argparse.Namespace, camera: dict[str, Any]) -> None:
        self.camera = camera
        self.source_centre = (float(camera["cu_px"]), float(camera["cv_px"]))
        self.size = _pair(args.pad, int, "x") if args.pad else (
            int(camera["width_px"]), int(camera["height_px"]))
        self.centre = _pair(args.centre) if args.centre else self.source_centre
        self.mount_deg = float(args.mount_deg)
        self.matrix = warp_matrix(self.source_centre, self.centre, self.mount_deg)

    def image(self, img: np.ndarray) -> np.ndarray:
        return transform_image(img, self.matrix, self.size)

    def exact_entry(self, map_origin: tuple[float, float]) -> dict[str, Any]:
        return {**self.camera, "width_px": self.size[0], "height_px": self.size[1],
                "cu_px": self.centre[0], "cv_px": self.centre[1],
                "mount_yaw_deg": self.mount_deg,
                "map_to_field": {"x_m": map_origin[0], "y_m": map_origin[1], "yaw_deg": 0.0}}


def _header(stamp_ns: int, frame: str) -> dict[str, Any]:
    from dsp import contract

    return {"stamp": contract.stamp_from_ns(stamp_ns), "frame_id": frame}


def convert(args: argparse.Namespace) -> None:
    from mcap.writer import CompressionType
    from mcap_ros2.writer import Writer

    from dsp import contract

    layout = _Layout(args, _camera(args.source))
    origin = _pair(args.map_origin)
    offset = int(args.epoch) * 1_000_000_000
    robots = set()
    with args.output.open("wb") as f:
        writer = Writer(f, chunk_size=4 << 20, compression=CompressionType.ZSTD)
        schemas = {n: writer.register_msgdef(n, t) for n, t in contract.MESSAGE_DEFINITIONS.items()}
        for topic, msg, log_time in _messages(args.source):
            t = log_time + offset
            parts = topic.strip("/").split("/")
            if topic == contract.GT_BALL_TOPIC:
                p = msg.pose.position
                writer.write_message(TRUTH_TOPIC, schemas[contract.POSE_STAMPED], {
                    "header": _header(t, contract.FIELD_FRAME),
                    "pose": {"position": {"x": p.x, "y": p.y, "z": p.z},
                             "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
                    log_time=t, publish_time=t)
            elif len(parts) == 2 and parts[1] == "pose":
                robot, p, q = parts[0], msg.pose.position, msg.pose.orientation
                pose = {"position": {"x": p.x - origin[0], "y": p.y - origin[1], "z": p.z},
                        "orientation": {"x": q.x, "y": q.y, "z": q.z, "w": q.w}}
                writer.write_message(
                    POSE_TOPIC.format(robot=robot), schemas[contract.POSE_WITH_COVARIANCE_STAMPED],
                    {"header": _header(t, "map"), "pose": {"pose": pose, "covariance": [0.0] * 36}},
                    log_time=t, publish_time=t)
            elif topic.endswith("/omni/image/compressed"):
                robot = parts[0]
                robots.add(robot)
                img = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8), cv2.IMREAD_COLOR)
                _write_image(writer, schemas, robot, t, layout.image(img), args.encoding)
        writer.finish()
    if args.exact_cameras is not None:
        from dsp.camera_file import camera_file_text

        args.exact_cameras.write_text(camera_file_text(
            {"default": layout.exact_entry(origin)}, args.exact_cameras.suffix,
            header=f"The converted camera of {args.output.name}, described exactly "
            "(scripts/team_example.py convert --exact-cameras), and the field it was "
            "recorded on.", field=_field(args.source)), encoding="utf-8")
    print(f"wrote {args.output}: {len(robots)} robots, images {layout.size[0]} x "
          f"{layout.size[1]} centred at {layout.centre}, mounted at {layout.mount_deg:g} deg")


def _write_image(writer: Any, schemas: dict[str, Any], robot: str, t: int, img: np.ndarray,
                 encoding: str) -> None:
    from dsp import contract

    header = _header(t, f"{robot}/camera")
    topic = IMAGE_TOPIC.format(robot=robot)
    if encoding == "png":
        ok, buf = cv2.imencode(".png", img)
        assert ok
        writer.write_message(topic, schemas[contract.COMPRESSED_IMAGE],
                             {"header": header, "format": "png", "data": buf.tobytes()},
                             log_time=t, publish_time=t)
        return
    writer.write_message(topic, schemas[contract.IMAGE], {
        "header": header, "height": img.shape[0], "width": img.shape[1], "encoding": "bgr8",
        "is_bigendian": 0, "step": img.shape[1] * 3, "data": img.tobytes()},
        log_time=t, publish_time=t)


def measure(args: argparse.Namespace) -> None:
    from estimator.camera import camera_from_dict
    from estimator.detection import detect_ball
    from recorder.omni import OmniRenderer
    from recorder.world import World, field_spec

    layout = _Layout(args, _camera(args.source))
    omni = OmniRenderer(camera_from_dict(dict(layout.camera)))
    rng = np.random.default_rng(args.seed)
    rows = ["u_px,v_px,range_m,angle_deg"]
    with World(field_spec("18x12"), renderer=args.renderer) as world:
        world.add_robot("robot1")
        while len(rows) <= args.points:
            d, a = rng.uniform(0.5, 8.5), rng.uniform(-180.0, 180.0)
            x, y = d * math.cos(math.radians(a)), d * math.sin(math.radians(a))
            if abs(x) > 9.0 or abs(y) > 6.0:  # on the carpet
                continue
            # where the ball truly is, and the robot's true heading, off the measured ones
            tx, ty = x + rng.normal(0.0, BALL_POSITION_SIGMA_M), y + rng.normal(
                0.0, BALL_POSITION_SIGMA_M)
            yaw = math.radians(rng.normal(0.0, ROBOT_YAW_SIGMA_DEG))
            world.set_robot_pose("robot1", 0.0, 0.0, yaw)
            world.set_ball(tx, ty)
            det = detect_ball(layout.image(omni.render(world, "robot1", 0.0, 0.0, yaw)))
            if det is not None:
                rows.append(f"{det.cx_px:.3f},{det.cy_px:.3f},{d:.3f},{a:.2f}")
    args.output.write_text("# measured points: scripts/team_example.py measure\n"
                           + "\n".join(rows) + "\n", encoding="utf-8")
    print(f"wrote {args.output}: {args.points} points")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    sub = p.add_subparsers(dest="command", required=True)
    for name in ("convert", "measure"):
        s = sub.add_parser(name)
        s.add_argument("source", type=Path, help="a log dsp-record wrote")
        s.add_argument("output", type=Path)
        s.add_argument("--pad", metavar="WxH", help="the team camera's image size")
        s.add_argument("--centre", metavar="CU,CV", help="where the image centre lands")
        s.add_argument("--mount-deg", type=float, default=0.0,
                       help="the robot-frame direction image up shows (90: left)")
    conv = sub.choices["convert"]
    conv.add_argument("--map-origin", default="-9,-6", metavar="X,Y",
                      help="the map frame's origin in the field (default -9,-6: a corner)")
    conv.add_argument("--epoch", type=int, default=EPOCH_S, help="stamps from this Unix second")
    conv.add_argument("--encoding", choices=("bgr8", "png"), default="bgr8")
    conv.add_argument("--exact-cameras", type=Path, metavar="FILE",
                      help="also write the camera file that describes the camera exactly")
    meas = sub.choices["measure"]
    meas.add_argument("--points", type=int, default=40)
    meas.add_argument("--seed", type=int, default=1)
    meas.add_argument("--renderer", default="auto")
    return p


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(ROOT))
    args = build_parser().parse_args(argv)
    from replay.log.catalogue import check_mcap_file

    check_mcap_file(Path(args.source))  # a missing file, a folder, not MCAP: one line
    (convert if args.command == "convert" else measure)(args)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    from dsp.cli import run_main

    sys.exit(run_main("team_example.py", main))
