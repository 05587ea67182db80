"""What a URDF says about each link besides its name: meshes, geometry, mass, simulator sensors and plugins.

Extracted once at ingestion from the validated document and carried by the KinematicTree, then
rendered as a few words in the questions that concern a link (the model still decides). Simulator
sensor declarations use SDF's closed vocabulary of sensor types (`camera`, `depth`, `ray`, `imu`,
`contact`, ...); the older Gazebo form `<sensor:camera>` / `<sensor:ray>` of PR2-era files is read
as the same types. A declaration is attached to the link it references and to the link its
plugin publishes in (`frameName`), when that is another link of the robot; one declared on a joint (a force-torque
sensor, as Gazebo wants it), to the frame fixed on the joint's child where the sensor's `<pose>` puts it. The numbers it states
(rate, field of view, image size, rays, range) are kept in SI units whichever form wrote them
(the old form gives angles in degrees); a number it does not state, or states unreadably, is None.
A ray sensor publishing ROS range messages (one distance valid over a cone) states in its plugin what it emits
(`radiation`, `radiation_type`: the message's ultrasound or infrared) and, where the ray block states no scan,
the cone's angle (`fov`), read as the span it measures across.
A `depth` sensor whose plugin publishes its image in a colour topic reads as SDF's `rgbd_camera` (SimSensor.sdf_type).
A simulator plugin outside any sensor (a vacuum gripper's, a grasp helper's) that names a link of the robot in
an element naming a link, body or frame gives that link its library's stem, which the product catalogue reads as it
reads mesh stems (pipeline.abstraction.stages.identification.named_product); questions do not show it.
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, fields
from typing import Any, Iterable, Iterator, Mapping

from urdfkb.pipeline.reading.rotation import rotate_rpy

MAX_MESHES = 2  # mesh stems shown per link (visual first)
_PLUGIN_STEM = re.compile(r"^(?:lib)?(.+?)(?:\.so|\.dll|\.dylib)?$")


@dataclass(frozen=True)
class SimSensor:
    """One simulator sensor declaration: its SDF type, plugin library stems, the links it names and the
    numbers it states (None where it states none)."""

    type: str
    plugins: tuple[str, ...] = ()
    reference: str = ""               # the link its <gazebo reference="..."> block names (or puts it on: a joint's)
    frame: str | None = None          # the link its plugin expresses its data in (frameName), where one of the robot's
    rate: float | None = None         # Hz: how often it updates (its own update_rate / updateRate)
    fov: float | None = None          # rad: a camera's horizontal field of view, a ray sensor's horizontal span
    image: tuple[int, int] | None = None  # a camera's image width and height in pixels
    samples: int | None = None        # rays per horizontal scan
    min_range: float | None = None    # m: a ray sensor's nearest and farthest measured distance
    max_range: float | None = None
    resolution: float | None = None   # m: a ray sensor's range resolution
    colour: bool = False              # it gives colour images (_gives_colour)
    depth: bool = False               # its plugin publishes depth beside its images (_gives_depth)
    pixels: str | None = None         # the pixel format its images are written in (SDF's <format>, as written)
    radiation: str | None = None      # what a one-beam ranger emits, as its ROS range plugin states it (_RADIATIONS)
    name: str = ""                    # the name the file gives the declaration (`<sensor name="...">`)
    places: tuple[tuple[float, float, float], ...] = ()  # where each of its cameras sees from, in its link's frame

    @property
    def ranging(self) -> bool:
        """A ray sensor (SDF `ray`, `gpu_ray`, `lidar`, `gpu_lidar`): its `fov` is the span it measures across."""
        return _is_ranging(self.type)

    @property
    def sdf_type(self) -> str:
        """The SDF sensor type the declaration amounts to: a Gazebo classic `depth` sensor whose plugin publishes a
        colour image beside the depth (the openni_kinect plugin's RGB-D mode), or a `camera` whose plugin publishes
        depth beside its image (that plugin on an old Gazebo's camera sensor), is SDF's `rgbd_camera`."""
        if (self.type == "depth" and self.colour) or (self.type == "camera" and self.depth):
            return "rgbd_camera"
        return self.type


@dataclass(frozen=True)
class LinkEvidence:
    """Facts about one link: mesh file stems, its first primitive shape, mass and centre of mass, declared sensors,
    the stems of the simulator plugins that name it (outside sensors)."""

    meshes: tuple[str, ...] = ()
    shape: str = ""            # "box 0.1x0.2x0.3 m", "cylinder r=0.05 l=0.1 m", "sphere r=0.02 m", or ""
    mass: float | None = None  # None when the link has no <inertial>
    sensors: tuple[SimSensor, ...] = ()
    collision_only: bool = False  # it has <collision> geometry and no <visual>
    plugins: tuple[str, ...] = ()
    centre: tuple[float, float, float] | None = None  # centre of mass in the link's frame; None without <inertial>
    drawn_at: tuple[float, float, float] | None = None  # where its primitive shape is centred, in the link's frame

    @classmethod
    def from_dict(cls, data: dict) -> LinkEvidence:
        """Inverse of dataclasses.asdict (a tree stored before `collision_only`, `plugins`, `centre` or `drawn_at` was
        kept reads them empty)."""
        centre, drawn_at = data.get("centre"), data.get("drawn_at")
        return cls(tuple(data["meshes"]), data["shape"], data["mass"], tuple(map(_sensor, data["sensors"])),
                   bool(data.get("collision_only", False)), tuple(data.get("plugins", ())),
                   None if centre is None else (float(centre[0]), float(centre[1]), float(centre[2])),
                   None if drawn_at is None else (float(drawn_at[0]), float(drawn_at[1]), float(drawn_at[2])))

    @property
    def is_pure_frame(self) -> bool:
        """No geometry at all: a coordinate frame rather than a body."""
        return not self.meshes and not self.shape

    def _sizes(self) -> tuple[str, list[float]]:
        """Its primitive shape's kind and the numbers `shape` gives for it (box sides; cylinder r, l; sphere r)."""
        kind, _, sizes = self.shape.partition(" ")
        return kind, [float(n) for n in re.findall(r"[-+]?\d*\.?\d+(?:e[-+]?\d+)?", sizes)]

    @property
    def extent(self) -> float | None:
        """The largest dimension of its primitive shape in metres (None without one, or with a mesh)."""
        if self.meshes or not self.shape:
            return None
        kind, numbers = self._sizes()
        if kind == "box":
            return max(numbers, default=0.0)
        return max([2 * numbers[0], *numbers[1:]]) if numbers else None  # cylinder r, l; sphere r

    @property
    def cylinder(self) -> tuple[float, float] | None:
        """Radius and length of its primitive shape where that is a cylinder (None otherwise)."""
        kind, numbers = self._sizes()
        return (numbers[0], numbers[1]) if kind == "cylinder" and len(numbers) >= 2 else None

    def text(self) -> str:
        """The link's geometry in a few words, or '' when it has none worth saying. Declared simulator
        sensors are not rendered: they narrow the classes offered (pipeline.abstraction.steps.classify._ruled_out) instead."""
        parts = [f"mesh {', '.join(self.meshes)}"] if self.meshes else []
        if self.shape:
            parts.append(self.shape)
        if self.is_pure_frame:
            parts.append("no geometry" + (", massless" if not self.mass else ""))
        return "; ".join(parts)


def _sensor(data: dict[str, Any]) -> SimSensor:
    """A SimSensor from its asdict form; a tree stored before the numbers were kept has a detail string instead."""
    known = {f.name for f in fields(SimSensor)}
    values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items() if k in known}
    values["places"] = tuple(tuple(p) for p in values.get("places", ()))
    return SimSensor(**values)


def extract(robot: ET.Element, links: Iterable[str]) -> dict[str, LinkEvidence]:
    """Evidence for every link of a validated <robot> element."""
    known = set(links)
    sensors = _declared_sensors(robot, known)
    plugins = _naming_plugins(robot, known)
    found = {}
    for link in robot.findall("link"):
        name = link.get("name", "")
        if name in known:
            declared = tuple(dict.fromkeys(sensors.get(name, ())))  # one sensor may name a link twice
            collision_only = link.find("collision/geometry") is not None and link.find("visual/geometry") is None
            shape, drawn_at = _shape(link)
            found[name] = LinkEvidence(_meshes(link), shape, _mass(link), declared, collision_only,
                                       tuple(plugins.get(name, ())), _centre(link), drawn_at)
    return found


def named(evidence: Mapping[str, LinkEvidence], link: str) -> str:
    """The link's name followed by its facts in parentheses, or the bare name when it has none:
    stated next to the name rather than on a line of their own, the facts cost no repeated name."""
    text = evidence[link].text() if link in evidence else ""
    return f"{link} ({text})" if text else link


# -- geometry ---------------------------------------------------------------------------


def _meshes(link: ET.Element) -> tuple[str, ...]:
    stems = []
    for part in ("visual", "collision"):
        for mesh in link.findall(f"{part}/geometry/mesh"):
            stem = mesh_stem(mesh.get("filename", ""))
            if stem and stem not in stems:
                stems.append(stem)
    return tuple(stems[:MAX_MESHES])


def mesh_stem(filename: str) -> str:
    """The informative end of a mesh path: what follows its `meshes` folder (or its package),
    at most two components, without extension ('package://p/meshes/sensors/lds.stl' → 'sensors/lds')."""
    path = re.sub(r"^[a-z]+://", "", filename).replace("\\", "/").strip("/")
    parts = [p for p in path.split("/") if p]
    if not parts:
        return ""
    lowered = [p.lower() for p in parts]
    if "meshes" in lowered[:-1]:
        parts = parts[len(lowered) - lowered[::-1].index("meshes"):]
    elif len(parts) > 1 and filename.startswith("package://"):
        parts = parts[1:]
    parts[-1] = parts[-1].rsplit(".", 1)[0]
    return "/".join(parts[-2:])


def _shape(link: ET.Element) -> tuple[str, tuple[float, float, float] | None]:
    """The first visual's primitive shape (else the first collision's) in words, and the origin it is drawn at."""
    for part in ("visual", "collision"):
        element = next((e for e in link.findall(part) if e.find("geometry") is not None), None)
        geometry = element.find("geometry") if element is not None else None
        if element is None or geometry is None:
            continue
        for shape in geometry:
            text = _shape_text(shape)
            if text:
                return text, _origin_xyz(element)
    return "", None


def _shape_text(shape: ET.Element) -> str:
    try:
        if shape.tag == "box":
            return "box " + "x".join(_num(v) for v in shape.get("size", "").split()) + " m"
        if shape.tag == "cylinder":
            return f"cylinder r={_num(shape.get('radius'))} l={_num(shape.get('length'))} m"
        if shape.tag == "sphere":
            return f"sphere r={_num(shape.get('radius'))} m"
    except (TypeError, ValueError):
        return ""
    return ""


def _num(value: str | None) -> str:
    return f"{float(value):.3g}"  # type: ignore[arg-type]


def _mass(link: ET.Element) -> float | None:
    mass = link.find("inertial/mass")
    if mass is None:
        return None
    try:
        value = float(mass.get("value", "0"))
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _centre(link: ET.Element) -> tuple[float, float, float] | None:
    """The <inertial> origin's xyz (the URDF default: the link's origin), or None without <inertial> or with a
    malformed or non-finite one."""
    inertial = link.find("inertial")
    return _origin_xyz(inertial) if inertial is not None else None


def _origin_xyz(element: ET.Element) -> tuple[float, float, float] | None:
    """The xyz of `element`'s <origin> (URDF's default: 0 0 0), or None where it is malformed or not finite."""
    origin = element.find("origin")
    xyz = _floats(origin.get("xyz", "0 0 0") if origin is not None else "0 0 0", 3)
    return (xyz[0], xyz[1], xyz[2]) if xyz is not None else None


# -- simulator sensors ------------------------------------------------------------------


def _declared_sensors(robot: ET.Element, known: set[str]) -> dict[str, list[SimSensor]]:
    """link → sensors declared in `<gazebo reference="link">` blocks (and at their output frame). A sensor declared
    on a joint (Gazebo's way for a force-torque sensor) belongs to the frame its <pose> puts it at (`_at_joint`)."""
    found: dict[str, list[SimSensor]] = {}
    joints = {j.get("name"): j for j in robot.findall("joint")}
    declaring = {g.get("reference") for g in robot.findall("gazebo") if any(_sensor_type(e) for e in g)}
    for gazebo in robot.findall("gazebo"):
        named_link = gazebo.get("reference")
        if named_link not in known and named_link not in joints:
            continue
        for element in gazebo:
            sensor_type = _sensor_type(element)
            if sensor_type is None:
                continue
            reference = (named_link if named_link in known
                         else _at_joint(robot, joints[named_link], element, known - declaring))
            if reference is None:
                continue
            frames = _output_frames(element, known)
            sensor = SimSensor(sensor_type, _plugins(element), reference, frames[0] if frames else None,
                               **_numbers(element, sensor_type), colour=_gives_colour(element, sensor_type),
                               depth=_gives_depth(element),
                               pixels=_child_text(element, "camera/image/format") or None,
                               name=(element.get("name") or "").strip(),
                               places=_camera_places(element) if named_link in known else ())
            for link in dict.fromkeys([reference, *frames]):
                found.setdefault(link, []).append(sensor)
    return found


AT_POSE = 0.001  # m: a frame this close to a joint sensor's <pose> is where the sensor is


def _at_joint(robot: ET.Element, joint: ET.Element, sensor: ET.Element, free: set[str]) -> str | None:
    """The link a sensor declared on `joint` is: the one frame among `free` (links declaring no sensor of their own)
    fixed at the sensor's <pose> (SDF gives a joint sensor's pose in the joint's frame, URDF's child frame): on the
    joint's child there, or, for a pose at the joint itself (none written: SDF's default), on the joint's parent where
    the joint is (the measurement frame written beside the joint, as a humanoid's force-torque sensors are). None
    where no one such frame sits there: the joint alone places it between two bodies, no link of its own."""
    child, parent = joint.find("child"), joint.find("parent")
    pose = _floats(sensor.findtext("pose") or "0 0 0 0 0 0", 6)
    if child is None or parent is None or pose is None:
        return None
    at_joint = math.dist(pose[:3], (0.0, 0.0, 0.0)) <= AT_POSE
    places = {child.get("link"): pose[:3]}
    if at_joint and (origin := _origin_xyz(joint)) is not None:
        places[parent.get("link")] = origin
    at = []
    for frame in robot.findall("joint"):
        on, link = frame.find("parent"), frame.find("child")
        if (frame is not joint and frame.get("type") == "fixed" and on is not None and on.get("link") in places
                and link is not None and link.get("link") in free):
            xyz = _origin_xyz(frame)
            if xyz is not None and math.dist(xyz, places[on.get("link")]) <= AT_POSE:
                at.append(link.get("link"))
    return at[0] if len(at) == 1 else None


def _camera_places(sensor: ET.Element) -> tuple[tuple[float, float, float], ...]:
    """Where each `<camera>` of an SDF sensor sees from in the frame of the link it is declared on: the camera's
    <pose> after the sensor's (SDF's default for either: none, the link's origin); () for another form, a sensor
    with no camera, or a pose not written as six finite numbers."""
    if _local(sensor.tag) != ("", "sensor"):
        return ()
    own = _floats(sensor.findtext("pose") or "0 0 0 0 0 0", 6)
    places = []
    for camera in (c for c in sensor.iter() if _local(c.tag)[1] == "camera"):
        pose = _floats(camera.findtext("pose") or "0 0 0 0 0 0", 6)
        if own is None or pose is None:
            return ()
        turned = rotate_rpy((own[3], own[4], own[5]), (pose[0], pose[1], pose[2]))
        places.append((own[0] + turned[0], own[1] + turned[1], own[2] + turned[2]))
    return tuple(places)


def _floats(text: str | None, n: int) -> tuple[float, ...] | None:
    """`n` finite numbers written in `text`, or None."""
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        return None
    return values if len(values) == n and all(map(math.isfinite, values)) else None


def _naming_plugins(robot: ET.Element, known: set[str]) -> dict[str, list[str]]:
    """link → stems of the plugins outside sensors (in any `<gazebo>` block) that name it in an element of their
    own whose tag says it names a link, a body or a frame (`<bodyName>`, `<gripper_link>`, `<palm_link>`,
    `<colorOpticalframeName>`; not a namespace, topic or joint)."""
    found: dict[str, list[str]] = {}
    for gazebo in robot.findall("gazebo"):
        for plugin in (e for e in _outside_sensors(gazebo, into_plugins=True) if _local(e.tag)[1] == "plugin"):
            if not (stem := _library_stem(plugin)):
                continue
            for element in (e for e in _outside_sensors(plugin, into_plugins=False) if _local(e.tag)[1] != "plugin"):
                tag, name = _local(element.tag)[1].lower(), (element.text or "").strip().lstrip("/")
                if name in known and "joint" not in tag and any(w in tag for w in ("link", "body", "frame")):
                    stems = found.setdefault(name, [])
                    if stem not in stems:
                        stems.append(stem)
    return found


def _outside_sensors(element: ET.Element, into_plugins: bool) -> Iterator[ET.Element]:
    """The elements below `element` that no sensor holds; inside the plugins among them too if `into_plugins` (a
    plugin's own elements are not those of the plugins it holds)."""
    for child in element:
        if child.tag == "sensor" or _sensor_type(child) is not None:
            continue
        yield child
        if into_plugins or _local(child.tag)[1] != "plugin":
            yield from _outside_sensors(child, into_plugins)


def _local(tag: str) -> tuple[str, str]:
    """(namespace, local name) of an ElementTree tag."""
    if tag.startswith("{"):
        ns, local = tag[1:].split("}", 1)
        return ns, local
    return "", tag


def _sensor_type(element: ET.Element) -> str | None:
    """SDF's `<sensor type="T">`, or T of the old Gazebo `<sensor:T>` (namespace ending '#sensor')."""
    ns, local = _local(element.tag)
    if not ns and local == "sensor":
        kind = (element.get("type") or "").strip().lower()
        return kind or None
    if ns.endswith("#sensor"):
        return local.lower()
    return None


def _plugins(sensor: ET.Element) -> tuple[str, ...]:
    return tuple(dict.fromkeys(stem for element in _plugin_elements(sensor) if (stem := _library_stem(element))))


def _library_stem(element: ET.Element) -> str | None:
    """The stem of the library an element loads (`filename`, or `plugin` in SDF's older form), or None."""
    library = element.get("filename") or element.get("plugin")
    match = _PLUGIN_STEM.match(library.rsplit("/", 1)[-1]) if library else None
    return match.group(1) if match else None


def _output_frames(sensor: ET.Element, known: set[str]) -> list[str]:
    """Links named by the plugin as the frame its data is expressed in."""
    frames = []
    for element in sensor.iter():
        if _local(element.tag)[1] in ("frameName", "frame_name", "frame_id", "gaussianNoiseFrame"):
            name = (element.text or "").strip().lstrip("/")
            if name in known:
                frames.append(name)
    return frames


_COLOUR_WORDS = frozenset({"rgb", "color", "colour"})
_COLOUR_FORMATS = frozenset({"r8g8b8", "b8g8r8", "rgb_int8", "bgr_int8"})  # SDF's pixel formats of colour images


def _gives_colour(sensor: ET.Element, sensor_type: str) -> bool:
    """A camera gives colour when its `<format>` is a colour one. A `depth` sensor's format is only that of its
    preview image: it gives colour when its plugin names its image topic (`imageTopicName`, the ROS camera and openni
    plugins' parameter) in the colour stream of the ROS camera conventions: an `rgb/`, `color/` or `colour/`
    namespace (rgbd_launch, RealSense), or a name ending `_color` (image_proc's `image_rect_color`). An `ir/` or
    unnamed image (`aligned_depth_to_color/...` names a depth image), or no format, says nothing."""
    if sensor_type != "depth":
        return any(_local(e.tag)[1] == "format" and (e.text or "").strip().lower() in _COLOUR_FORMATS
                   for e in sensor.iter())
    for element in sensor.iter():
        if _local(element.tag)[1] == "imageTopicName":
            segments = [p for p in (element.text or "").strip().lower().split("/") if p]
            if _COLOUR_WORDS.intersection(segments[:-1]) or (segments and segments[-1].endswith("_color")):
                return True
    return False


_DEPTH_OUTPUTS = ("depthimage", "pointcloud")  # the ROS camera plugins' depth image and point cloud parameters


def _gives_depth(sensor: ET.Element) -> bool:
    """Its plugin publishes a depth image or a point cloud: it names one (the ROS openni_kinect and depth camera
    plugins' `depthImageTopicName`, `pointCloudTopicName`)."""
    return any(_local(e.tag)[1].lower().startswith(_DEPTH_OUTPUTS) for e in sensor.iter())


def _child_text(element: ET.Element, path: str) -> str | None:
    """Text at `path` (local names, '/'-separated), ignoring namespaces."""
    current = [element]
    for step in path.split("/"):
        current = [c for e in current for c in e if _local(c.tag)[1] == step]
    return (current[0].text or "").strip() if current else None


def _number(element: ET.Element, *paths: str) -> float | None:
    """The finite number at the first of `paths` (see _child_text) that is present, else None."""
    text = next((t for p in paths if (t := _child_text(element, p)) is not None), None)
    try:
        value = float(text) if text is not None else math.nan
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _positive(value: float | None) -> float | None:
    return value if value is not None and value > 0 else None


def _numbers(sensor: ET.Element, sensor_type: str) -> dict:
    """The numbers a declaration states, by SimSensor field: SDF (`<camera>`, `<ray>` or `<lidar>`, radians)
    or the old Gazebo form (`imageSize`, `hfov`, `rayCount`, `minAngle`: degrees). An update rate of 0 (as
    fast as the simulator runs) states no rate."""
    found: dict = {"rate": _positive(_number(sensor, "update_rate", "updateRate"))}
    if _local(sensor.tag) == ("", "sensor"):  # SDF: the first <camera> below it (a multicamera has several)
        camera = next((c for c in sensor.iter() if _local(c.tag)[1] == "camera"), None)
        if camera is not None:
            found["fov"] = _positive(_number(camera, "horizontal_fov"))
            found["image"] = _image(_number(camera, "image/width"), _number(camera, "image/height"))
    else:
        hfov = _number(sensor, "hfov")
        found["fov"] = _positive(math.radians(hfov) if hfov is not None else None)
        size = (_child_text(sensor, "imageSize") or "").split()
        found["image"] = _image(*map(_float, size)) if len(size) == 2 else None
    if _is_ranging(sensor_type):
        found.update(_ray_numbers(sensor))
    return found


def _is_ranging(sensor_type: str) -> bool:
    return sensor_type.endswith("ray") or sensor_type.endswith("lidar")


def _image(width: float | None, height: float | None) -> tuple[int, int] | None:
    return (int(width), int(height)) if width and height and width >= 1 and height >= 1 else None


def _ray_numbers(sensor: ET.Element) -> dict:
    """Rays per horizontal scan, their span, range and range resolution: SDF `<ray>` / `<lidar>` or the old
    `rayCount`, `minAngle`/`maxAngle` (degrees), `minRange`, `maxRange`, `resRange`."""
    block = next((b for b in ("ray", "lidar") if _child_text(sensor, b) is not None), None)
    if block is not None:
        scan = f"{block}/scan/horizontal"
        samples = _number(sensor, f"{scan}/samples")
        low, high = _number(sensor, f"{scan}/min_angle"), _number(sensor, f"{scan}/max_angle")
        span = high - low if low is not None and high is not None else None
        minimum, maximum, resolution = (_number(sensor, f"{block}/range/{n}") for n in ("min", "max", "resolution"))
    else:
        samples = _number(sensor, "rayCount")
        low, high = _number(sensor, "minAngle"), _number(sensor, "maxAngle")
        span = math.radians(high - low) if low is not None and high is not None else None
        minimum, maximum, resolution = (_number(sensor, n) for n in ("minRange", "maxRange", "resRange"))
    if span is None:  # a range plugin's cone (gazebo_ros_range's `fov`), where the ray block states no span
        span = next((n for p in _plugin_elements(sensor) if (n := _number(p, "fov")) is not None), None)
    return {"samples": int(samples) if samples is not None and samples >= 1 else None, "fov": _positive(span),
            "min_range": minimum if minimum is not None and minimum >= 0 else None,
            "max_range": _positive(maximum), "resolution": _positive(resolution), "radiation": _radiation(sensor)}


_RADIATIONS = frozenset({"ultrasound", "infrared"})  # sensor_msgs/Range's radiation types


def _plugin_elements(sensor: ET.Element) -> list[ET.Element]:
    """The plugins a declaration loads: SDF's `<plugin>`, the old form's `<controller:...>` (any element loading a
    library)."""
    return [e for e in sensor.iter() if _local(e.tag)[1] == "plugin" or _library_stem(e)]


def _radiation(sensor: ET.Element) -> str | None:
    """What a range plugin says its sensor emits: `radiation` (ROS 1 gazebo_ros_range) or `radiation_type` (ROS 2
    gazebo_ros_ray_sensor), when it is one of sensor_msgs/Range's two; None where stated by none or differently."""
    stated = {text for p in _plugin_elements(sensor) for e in p if _local(e.tag)[1] in ("radiation", "radiation_type")
              if (text := (e.text or "").strip().lower())}
    return stated.pop() if len(stated) == 1 and stated <= _RADIATIONS else None


def _float(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None
