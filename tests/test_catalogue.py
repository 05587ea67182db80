"""The hardware product catalogue (ontologies/products.ttl, pipeline.abstraction.catalogue) and where it reaches the questions."""
from __future__ import annotations

import random

import pytest
from rdflib.namespace import OWL

from tests.urdf_writer import Writer

from urdfkb.pipeline.abstraction.catalogue import Catalogue, Product, catalogue, load
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.namespaces import CORE
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.prompts import kind_choice, level_options, product_text
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.identification import named_product
from urdfkb.pipeline.abstraction.alike import alike_sets
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.steps.classify import chain_subject, post_classification, pre_classification
from urdfkb.pipeline.abstraction.stages.sensor_check import not_sensors
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.reading.ingest import load_urdf

TAX = vocabulary()


def test_the_packaged_catalogue_names_sixty_products_each_a_core_device_with_its_source():
    products = catalogue().products
    assert len([p for p in products if TAX.is_a(p.cls, TAX.component)]) >= 60
    for p in products:
        assert p.fragments and p.source and p.label, p
        # a device, or something the core declares disjoint with every component (a fiducial marker)
        assert TAX.is_a(p.cls, "Sensor") or TAX.is_a(p.cls, "EndEffector") or \
            (CORE[p.cls], OWL.disjointWith, CORE[TAX.component]) in TAX.graph, p
    kinds = {p.cls for p in products}
    assert {"RGBDCamera", "StereoCamera", "Lidar", "IMU", "ForceTorqueSensor", "MicrophoneArray",
            "ParallelGripper", "AnthropomorphicHand"} <= kinds


@pytest.mark.parametrize("name, label", [
    ("D435i_camera_link", "Intel RealSense D435"),
    ("pelvis_realsense_d430_link", "Intel RealSense Depth Module D410 / D420 / D430 / D450"),  # not the family's
    ("d430_depth_frame", "Intel RealSense Depth Module D410 / D420 / D430 / D450"),
    ("base_laser_velodyne_vlp16", "Velodyne lidar"),
    ("mid360_link", "Livox Mid-360"),
    ("os_sensor", "Ouster OS lidar"),  # the sensor frame its ROS driver names
    ("meshes/bendy_sucker.dae", "suction cup"),  # the generic word for the cup
    ("button_power", "push button"),  # the generic kind
    ("ChestButton_frame", "push button"),
    ("sensors/lds", "ROBOTIS LDS"),
    ("zed2_left_camera_frame", "Stereolabs ZED"),
    ("oak-d-pro_frame", "Luxonis OAK-D"),  # a hyphen parts words too
    ("oak_rgb_camera_optical_frame", "Luxonis OAK-D"),  # depthai-ros's default device name
    ("oak1_imu_frame", "Luxonis OAK-D"),  # a second device, numbered
    ("soak_tank_link", None),     # "oak" inside a word
    ("oaken_panel", None),        # "oak" followed by letters
    ("head/swissranger_frame", "MESA SwissRanger"),
    ("front_tfmini_link", "Benewake TFmini / TF-Luna / TF02"),
    ("base_lidar_lite_v3", "Garmin LIDAR-Lite"),
    ("robot/tof/front_center", "time-of-flight rangefinder"),  # the generic kind, a single beam
    ("head_tof_camera_optical", "time-of-flight camera"),      # the longer fragment: a depth image
    ("toffee_link", None),
    ("vectorNav", "VectorNav VN-100"),  # a product name written in camel case is one word too
    ("base/us_2_frame", "ultrasonic sensor"),  # the generic abbreviation
    ("rov/ping360_sonar", "Blue Robotics Ping360"),  # the longer fragment
    ("ping_sensor_array", "Parallax PING))) ultrasonic sensor"),
    ("pinger_link", None),        # "ping" followed by letters: an acoustic pinger emits
    ("scanse_sweep", "Scanse Sweep"),
    ("neato_laser", "Neato XV-11 laser distance sensor"),
    ("floor_reflectance_3", "infrared reflectance sensor"),
    ("base_scan_front_multilayer", "multi-layer laser scanner"),
    ("usb_cam_link", None),       # "us" followed by letters
    ("bus_bar_link", None),       # "us" inside a word
    ("left_sdh_palm", "Schunk SDH"),
    ("sdhx_frame", None),         # "sdh" followed by letters
    ("normalized_frame", None),   # "zed" inside a word
    ("mtimes_link", None),        # "mti" followed by letters
    ("pos1_frame", None),         # "os1" not at a word start
])
def test_a_fragment_matches_where_a_word_starts(name, label):
    found = catalogue().match([name])
    assert (found.label if found else None) == label


def test_a_user_catalogue_adds_products(user_products):
    found = catalogue().match(["left_eyecam_frame"])
    assert found is not None and found.label == "Acme EyeCam"


def test_an_entry_of_no_core_class_is_refused(tmp_path):
    bad = tmp_path / "bad.ttl"
    bad.write_text('@prefix prod: <https://w3id.org/urdfkb/products#> .\n'
                   'prod:X a prod:Product ; prod:kind <http://example.org/Thing> ; prod:nameFragment "x" .\n')
    with pytest.raises(OntologyError, match="no prod:kind in the core"):
        load([bad])
    with pytest.raises(OntologyError, match="cannot read"):
        load([tmp_path / "missing.ttl"])


def test_the_identification_question_shows_a_named_product():
    product = Product("Livox Mid-360", "Lidar", ("mid360",), "Livox, Mid-360")
    shown = kind_choice(TAX, TAX.subclasses(TAX.component), "mid360_link", ["torso_link"], "fixed", product)
    plain = kind_choice(TAX, TAX.subclasses(TAX.component), "mid360_link", ["torso_link"], "fixed")
    assert shown.question.user.endswith("Product: Livox Mid-360 (" + TAX.label("Lidar") + ")")
    assert "Product" not in plain.question.user and shown.question.system == plain.question.system
    assert Catalogue([product]).match(["x_mid360"]) == product


def test_a_descent_shows_the_products_kinds_in_the_words_it_offers():
    """Below the class a descent starts from, the product's kinds are named path-wise in the answer phrases the
    questions offer: each product's first kind is one of the first question's options."""
    mics = Product("ReSpeaker", "MicrophoneArray", ("respeaker",), "Seeed, ReSpeaker Mic Array")
    assert product_text(TAX, mics, "Sensor") == "\nProduct: ReSpeaker (audio sensor > microphone array)"
    assert product_text(TAX, mics) == "\nProduct: ReSpeaker (" + TAX.label("MicrophoneArray") + ")"
    for product in catalogue().products:
        for kind in TAX.kinds.values():
            if TAX.is_a(product.cls, kind.cls) and product.cls != kind.cls:
                first = product_text(TAX, product, kind.cls).split("(", 1)[1].split(" > ")[0].rstrip(")")
                assert first in {TAX.answer(c) for c in level_options(TAX, kind.cls)}, product.label


@pytest.mark.parametrize("seed", range(3))
def test_a_simulator_sensors_name_names_its_product(seed):
    """A file may name a camera's product only in its simulator declaration (`<sensor name="...">` on a bare
    frame): the catalogue reads that name as it reads link names, meshes and plugins, and the question shows it.
    A sensor declared on the body a link is fixed to names no product for that link, a frame or a piece with
    geometry (a lidar declared on a base names neither the IMU frame nor the bracket beside it)."""
    import random
    from urdfkb.pipeline.abstraction.stages.identification import named_product
    from urdfkb.pipeline.reading.ingest import load_urdf
    from tests.urdf_writer import Writer
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    eye, other, frame = w.link(), w.link('<box size="0.02 0.02 0.02"/>'), w.link()
    w.joint("fixed", base, eye, xyz=(0.2, 0.0, 0.1))
    w.joint("fixed", base, other, xyz=(0.2, 0.1, 0.1))
    w.joint("fixed", base, frame, xyz=(0.0, 0.1, 0.1))
    declared = (f'<gazebo reference="{eye}"><sensor name="front_d435_sensor" type="camera"><camera>'
                f'<horizontal_fov>1.2</horizontal_fov></camera></sensor></gazebo>'
                f'<gazebo reference="{base}"><sensor name="base_vlp16" type="ray"/></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", declared.encode() + b"</robot>"))
    camera, lidar = named_product(tree, [eye]), named_product(tree, [base])
    assert camera is not None and camera.label == "Intel RealSense D435"
    assert lidar is not None and lidar.label == "Velodyne lidar" and named_product(tree, [other]) is None
    assert named_product(tree, [frame]) is None  # a lidar declared on the base names no bare frame fixed to it


def test_a_sensor_the_catalogue_names_of_no_kind_below_sensor_stays_a_sensor():
    """A GNSS receiver is a sensor of none of the kinds the core names below Sensor (a satellite navigation
    receiver's link was typed a camera, an IMU, a touch sensor): where a chain names it, its pre-classification
    stays at Sensor unasked, every kind below the product's class ruled out; an alike leaf beside it that names
    nothing is asked on its own (not answered with it) and offered only the kinds."""
    w = Writer(random.Random(5))
    base = w.link('<box size="0.5 0.4 0.2"/>')
    for leaf in ("navsat_link", "plate"):  # mounted as an underwater vehicle's file writes its sensors: no range
        w.links.append(f'<link name="{leaf}"/>')
        w.joint("revolute", base, leaf, (0.1, 0.0, 0.1), limits=(0.0, 0.0))
    tree = load_urdf(w.urdf())
    assert ["navsat_link", "plate"] in alike_sets(tree, ["navsat_link", "plate"], lambda a, b: True)
    seen = {}

    def rule(q):
        seen[q.key] = q.options
        return "other sensor" if "other sensor" in q.options else q.options[0]
    ctx = Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor")
    found = Findings(chains=[sub_chain(tree, leaf, base) for leaf in ("navsat_link", "plate")])
    pre_classification(ctx, found)
    assert "satellite navigation (GNSS) receiver" in chain_subject(ctx, tree, found.chains[0], "Sensor").evidence
    assert "pre:navsat_link@Sensor" not in seen and found.pre["navsat_link"].cls == "Sensor"
    assert "other sensor" not in seen["pre:plate@Sensor"] and found.pre["plate"].cls != "Sensor"


def test_a_device_of_several_chains_naming_a_sensor_of_no_kind_below_sensor_stays_a_sensor():
    """A boat's satellite receiver written as two antenna frames (a heading pair), grouped as one device: the model
    descends from Sensor to a vision sensor and a depth camera (as the real model did on a Clearpath Heron), but the
    product the links name rules every kind below Sensor out of post-classification as of pre-classification: the
    device stays a Sensor, unasked (on the code before: a depth camera)."""
    w = Writer(random.Random(6))
    base = w.link('<box size="1.3 1.0 0.3"/>')
    for leaf, x in (("navsat_link", 0.3), ("rear_navsat", -0.3)):
        w.links.append(f'<link name="{leaf}"/>')
        w.joint("fixed", base, leaf, (x, 0.0, 0.4))
    tree = load_urdf(w.urdf())
    seen = {}

    def rule(q):
        seen[q.key] = q.options
        return next((o for o in ("vision sensor", "depth camera") if o in q.options), q.options[0])
    ctx = Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor")
    found = Findings(chains=[sub_chain(tree, leaf, base) for leaf in ("navsat_link", "rear_navsat")])
    pre_classification(ctx, found)
    found.groups = [Group(list(found.chains))]
    post_classification(ctx, found)
    assert found.post[0].cls == "Sensor" and not any(key.startswith("post:") for key in seen)


@pytest.mark.parametrize("leaf", ["radar", "front_mmwave_link"])
def test_a_radar_is_shown_as_one_and_is_no_lidar_and_no_sonar(leaf):
    """A radar's link, bare (a quadruped's `radar` frame was typed an inertial measurement unit at 0.16 and held
    back): the catalogue's generic radio ranging sensor is shown with the link, and once the model places it among
    the ranging sensors no kind below is asked (a radar is neither a lidar nor a sonar)."""
    w = Writer(random.Random(4))
    base = w.link('<box size="0.6 0.3 0.15"/>')
    w.links.append(f'<link name="{leaf}"/>')
    w.joint("fixed", base, leaf, (0.3, 0.0, -0.05), rpy=(0.0, 2.88, 0.0))
    tree = load_urdf(w.urdf())
    product = named_product(tree, [leaf])
    assert product is not None and product.cls == "RangingSensor"
    seen = {}

    def rule(q):
        seen[q.key] = q.options
        return "ranging sensor" if "ranging sensor" in q.options else q.options[0]
    ctx = Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor")
    found = Findings(chains=[sub_chain(tree, leaf, base)])
    assert "radar" in chain_subject(ctx, tree, found.chains[0], "Sensor").evidence
    pre_classification(ctx, found)
    assert found.pre[leaf].cls == "RangingSensor" and f"pre:{leaf}@RangingSensor" not in seen


@pytest.mark.parametrize("leaf", ["front_tfmini_link", "ir_reflectance_sensor_2"])
def test_a_ranging_sensor_the_catalogue_places_at_ranging_sensor_is_no_lidar_and_no_sonar(leaf):
    """The catalogue names a product's most specific class: a single-beam time-of-flight ranger or an infrared
    reflectance sensor is a ranging sensor of neither kind below it, so its pre-classification stays there unasked
    whatever the model would say (on the code before: asked, and an e-puck's eight infrared proximity sensors were
    typed sonars); a bare leaf beside it is still asked."""
    w = Writer(random.Random(9))
    base = w.link('<box size="0.5 0.4 0.2"/>')
    for name in (leaf, "plate"):
        w.links.append(f'<link name="{name}"><visual><geometry><box size="0.01 0.01 0.01"/></geometry></visual></link>')
        w.joint("fixed", base, name, (0.2, 0.0 if name == leaf else 0.1, 0.05))
    tree = load_urdf(w.urdf())
    seen = {}

    def rule(q):
        seen[q.key] = q.options
        return "ranging sensor" if "ranging sensor" in q.options else "sonar" if "sonar" in q.options else q.options[0]
    ctx = Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor")
    found = Findings(chains=[sub_chain(tree, name, base) for name in (leaf, "plate")])
    pre_classification(ctx, found)
    assert found.pre[leaf].cls == "RangingSensor" and f"pre:{leaf}@RangingSensor" not in seen
    assert found.pre["plate"].cls == "Sonar"


def test_a_product_rules_out_the_kinds_beside_its_own_in_its_branch_and_no_other_branch():
    """A Doppler velocity log is a sonar: where the model calls its frame a ranging sensor, it is offered sonar or
    staying a ranging sensor, never lidar (on the code before: offered lidar, and an underwater vehicle's DVL was
    typed a lidar, 0.43); a frame inside a named camera that the model calls inertial is an inertial sensor still,
    offered every kind of it (the product rules out nothing outside its own branch)."""
    w = Writer(random.Random(11))
    base = w.link('<box size="0.5 0.4 0.2"/>')
    housing = w.link('<mesh filename="package://kit/meshes/d435.dae"/>')
    w.joint("fixed", base, housing, (0.2, 0.0, 0.1))
    for name, parent in (("dvl_link", base), ("cam_imu_frame", housing)):
        w.links.append(f'<link name="{name}"/>')
        w.joint("fixed", parent, name, (0.1, 0.05, -0.1))
    tree = load_urdf(w.urdf())
    seen = {}

    def rule(q):
        seen[q.key] = q.options
        first = {"dvl_link": "ranging sensor", "cam_imu_frame": "inertial sensor"}[q.key.split(":")[1].split("@")[0]]
        return first if first in q.options else "lidar" if "lidar" in q.options else q.options[0]
    ctx = Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor")
    found = Findings(chains=[sub_chain(tree, "dvl_link", base), sub_chain(tree, "cam_imu_frame", base)])
    pre_classification(ctx, found)
    assert "lidar" not in seen["pre:dvl_link@RangingSensor"] and found.pre["dvl_link"].cls == "Sonar"
    assert len(seen["pre:cam_imu_frame@InertialSensor"]) == len(TAX.subclasses("InertialSensor"))
    assert TAX.is_a(found.pre["cam_imu_frame"].cls, "InertialSensor")


def test_a_declared_type_rules_out_no_class_of_the_product_the_links_name():
    """A simulator stands a type it has in for a product it has none for (an underwater vehicle's scanning sonar
    swept as a GPU ray scan, SDF's lidar): the declaration rules the catalogue product's class in again (a
    sonar beside lidar), and still rules out the classes it disagrees with for a link that names no product."""
    w = Writer(random.Random(7))
    hull = w.link('<box size="0.45 0.34 0.25"/>')
    named, bare = "rov/ping360_sonar", "rov/scanner"
    for leaf, y in ((named, 0.1), (bare, -0.1)):
        w.links.append(f'<link name="{leaf}"><visual><geometry><cylinder radius="0.04" length="0.08"/></geometry>'
                       '</visual></link>')
        w.joint("fixed", hull, leaf, (0.15, y, 0.12))
    gazebo = "".join(f'<gazebo reference="{leaf}"><sensor name="s{i}" type="gpu_ray"><ray><scan><horizontal>'
                     '<samples>400</samples><min_angle>-3.14</min_angle><max_angle>3.14</max_angle></horizontal>'
                     '</scan></ray></sensor></gazebo>' for i, leaf in enumerate((named, bare)))
    tree = load_urdf(w.urdf().replace(b"</robot>", gazebo.encode() + b"</robot>"))
    ctx = Abstractor(Oracle(ScriptedBackend(lambda q: q.options[0])), TAX).context(tree, kind="sensor")
    sonar, scanner = (chain_subject(ctx, tree, sub_chain(tree, leaf, hull), "RangingSensor") for leaf in (named, bare))
    assert "Sonar" not in sonar.exclude and "Sonar" in scanner.exclude
    assert "Lidar" not in sonar.exclude  # the declared class stays offered: the model weighs the two


def test_a_sensor_declaration_named_for_a_product_its_type_rules_out_names_no_product():
    """A scan declared on a bare frame (a ray sensor) but named for a depth camera (a scan taken from one, or a name
    reused) names no product, so the declaration rules the cameras out; a depth sensor so named still names it, as
    a link named for a product does whatever its declaration."""
    w = Writer(random.Random(11))
    body = w.link('<box size="0.5 0.3 0.15"/>')
    scan, depth = w.name(), w.name()
    for leaf, y in ((scan, 0.05), (depth, -0.05)):
        w.links.append(f'<link name="{leaf}"/>')
        w.joint("fixed", body, leaf, (0.2, y, 0.1))
    gazebo = (f'<gazebo reference="{scan}"><sensor name="realsense" type="ray"><ray><scan><horizontal>'
              '<samples>180</samples><min_angle>-1.57</min_angle><max_angle>1.57</max_angle></horizontal></scan>'
              '</ray></sensor></gazebo>'
              f'<gazebo reference="{depth}"><sensor name="realsense" type="depth"/></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", gazebo.encode() + b"</robot>"))
    assert named_product(tree, [scan]) is None
    assert named_product(tree, [depth]) == catalogue().match(["realsense"])
    ctx = Abstractor(Oracle(ScriptedBackend(lambda q: q.options[0])), TAX).context(tree, kind="sensor")
    subject = chain_subject(ctx, tree, sub_chain(tree, scan, body), "Sensor")
    assert "VisionSensor" in subject.exclude and "\nProduct: " not in subject.evidence


def test_the_sensor_check_shows_the_product_a_leaf_names_as_identification_did():
    """A bare leaf named for an IMU product, identified as a sensor, was asked again without its product and
    called a passive part: the check shows the catalogue's line too, and a leaf naming nothing is asked as before."""
    w = Writer(random.Random(3))
    base = w.link('<box size="0.5 0.4 0.2"/>')
    named_leaf, plain_leaf = f"{w.name()}_microstrain", w.link()
    w.links.append(f'<link name="{named_leaf}"/>')
    w.joint("fixed", base, named_leaf, (0.1, 0.0, 0.1))
    w.joint("fixed", base, plain_leaf, (-0.1, 0.05, 0.12))
    tree = load_urdf(w.urdf())
    users = {}

    def check(q):
        users[q.key] = q.user
        return "sensor" if "\nProduct: " in users[q.key] else "passive part"
    dropped = not_sensors(Oracle(ScriptedBackend(check)), TAX, tree, [named_leaf, plain_leaf],
                          {named_leaf: 0.7, plain_leaf: 0.7}, lambda _m: None)
    assert dropped == [plain_leaf]
    assert users[f"check:{named_leaf}"].endswith(f"Product: LORD MicroStrain 3DM-GX5 ({TAX.label('IMU')})")
    assert "Product" not in users[f"check:{plain_leaf}"]


def test_alike_leaves_naming_different_products_are_checked_apart():
    """Two mirrored sensor heads on tilt joints, alike but for the product one's frame names: one check each, the
    product shown for its own leaf alone."""
    w = Writer(random.Random(4))
    base = w.link('<box size="0.5 0.4 0.2"/>')
    leaves = []
    for y, name in ((0.2, f"{w.name()}_microstrain"), (-0.2, w.name())):
        tilt = w.link('<box size="0.04 0.04 0.04"/>')
        w.joint("revolute", base, tilt, (0.0, y, 0.1), (0.0, 1.0, 0.0), (-0.5, 0.5))
        w.links.append(f'<link name="{name}"/>')
        w.joint("fixed", tilt, name, (0.03, 0.0, 0.0))
        leaves.append(name)
    tree = load_urdf(w.urdf())
    users = {}

    def check(q):
        users[q.key] = q.user
        return "sensor" if "\nProduct: " in q.user else "passive part"
    dropped = not_sensors(Oracle(ScriptedBackend(check)), TAX, tree, leaves, dict.fromkeys(leaves, 0.7), lambda _m: None)
    assert dropped == [leaves[1]] and set(users) == {f"check:{leaf}" for leaf in leaves}


@pytest.mark.parametrize("plugin", ["librotors_gazebo_imu_plugin.so", "libhector_gazebo_ros_imu.so"])
def test_an_imu_a_plugin_alone_simulates_is_declared_an_imu(plugin):
    """A drone's inertial frame that the simulator gives by a plugin naming the link, with no <sensor> (RotorS,
    hector): the plugin's library names the SDF type `imu`, which rules out the inertial kinds an IMU is not, as a
    <sensor type="imu"> would. The model, which calls the frame a gyroscope (as the real one did on a Crazyflie),
    is offered no gyroscope or accelerometer (on the code before: a gyroscope); a frame no plugin names still is."""
    w = Writer(random.Random(8))
    base = w.link('<box size="0.1 0.1 0.03"/>', centre=(0.0, 0.0, 0.0), mass=0.03)
    frames = [w.link(centre=(0.0, 0.0, 0.0), mass=0.001) for _ in range(2)]
    for frame in frames:
        w.joint("fixed", base, frame)
    block = (f'<gazebo><plugin filename="{plugin}" name="imu_plugin"><linkName>{frames[0]}</linkName>'
             '<imuTopic>imu</imuTopic></plugin></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", block.encode() + b"</robot>"))
    seen = {}

    def rule(q):
        seen[q.key] = q.options
        return next((o for o in ("inertial sensor", "gyroscope") if o in q.options), q.options[0])
    ctx = Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor")
    found = Findings(chains=[sub_chain(tree, frame, base) for frame in frames])
    pre_classification(ctx, found)
    assert found.pre[frames[0]].cls == "IMU" and found.pre[frames[1]].cls == "Gyroscope"
