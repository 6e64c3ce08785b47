"""Generate bracekit's shipped robot models (URDF) from documented numbers.

Usage: ``python tools/build_models.py [--out DIR]``

Writes ``puma560.urdf`` and ``paper_robot.urdf`` into ``src/bracekit/model/urdf``
(or DIR). Output is deterministic, so the committed files can be checked by
regenerating them. Only numpy and the standard library are used.

Assumptions
===========
PUMA 560 (both files)
  P1. Kinematics: standard DH table of Corke's Robotics Toolbox (mdl_puma560):
      a = [0, 0.4318, 0.0203, 0, 0, 0] m, d = [0, 0, 0.15005, 0.4318, 0, 0] m,
      alpha = [pi/2, 0, -pi/2, pi/2, -pi/2, 0], zero joint offsets.
      T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
  P2. No pedestal: the world frame (base_link) is DH frame 0, at the shoulder.
  P3. URDF mapping: joint i rotates about z of DH frame i-1; link i is DH
      frame i-1 turned by theta_i; Tz(d_i) Tx(a_i) Rx(alpha_i) is the origin
      of joint i+1 (i = 1..5) and of the fixed joint to frame 'flange'
      (i = 6, identity), so 'flange' is DH frame 6 (which is also the wrist
      centre, since row 6 is all zero).
  P4. Joint limits (deg): +-160, -45..225, -225..45, -110..170, +-100, +-266.
  P5. Effort/velocity limits are nominal placeholders for a PUMA 560, not
      datasheet values (no published source gives its joint torque limits);
      bracekit's torque ratios and actuator margins on the PUMA joints are
      therefore indicative only; give measured limits with effort=[...].
  P6. Inertials: Armstrong et al. (1986) as in Corke's toolbox (also KDL's
      puma560 model), moved from DH frame i into the URDF link frame. Two
      edits make the tensors physically valid (simulators reject others):
      link 1 has no identified mass (0 kg) and a single axial inertia 0.35;
      it gets a 1 kg placeholder and transverse inertias 0.18 kg m^2;
      link 3's Izz 0.0125 is raised to 0.0205 (triangle inequality).
      Inertials exist only so that URDF parsers and simulators accept the
      file.

HEBI arm of the paper robot (paper_robot.urdf only)
  H1. Five HEBI X8-16 modules, joints joint7..joint11, HEBI 5-DoF kit order
      (A-2085-05): actuator, heavy bracket, actuator, tube link (0.325 m,
      twist pi), actuator, tube link (0.325 m, twist pi), actuator, light
      bracket, actuator.
  H2. X8-16: output frame = input frame translated 0.0451 m along input z;
      the revolute joint sits at the output frame, axis +z. Housing mass
      0.5 kg with the centre of mass and inertia of HEBI's hebi_description
      X8 model. Joint limits +-2 pi (the module turns without limit; a
      finite range keeps the joint revolute, and two turns keep a path from
      being stopped by an artificial limit at +-pi), effort 38 Nm (peak; HEBI
      X-Series documentation, docs.hebi.us/hardware.html: X8-16 16 Nm
      continuous, 38 Nm peak), velocity
      1.571 rad/s (hebi_description value for the X8-16).
  H3. Tube link (extension L, twist tau): output = translation
      (L, -0.0175 sin tau, 0.0175 (1 + cos tau)) then Rx(tau).
      Mass 0.4 (L + 0.03) + 0.26 kg (hebi_description), thin-rod inertia.
  H4. Heavy bracket: handedness "right outside" (X5HeavyRightOutside, the
      one in HEBI's 5-DoF kit): output = translation (0, -0.0375, 0.055) then
      Rx(+pi/2). Mass 0.215 kg.
  H5. Light bracket (not among the published facts above): "right" (X5LightRight, the one in
      HEBI's 5-DoF kit), taken from HEBI's hebi_description bracket.xacro:
      output = translation (0, -0.043, 0.04) then Rx(+pi/2). Mass 0.1 kg.
  H6. Tool frame 'tool' = end effector {e}: 0.10 m along the output z axis
      of the last module (joint11), same orientation. A 0.05 kg placeholder
      (output hub and tool stub) is the inertial of link11.

Flange adapter and bracing frame (paper_robot.urdf only)
  A1. PUMA row 6 has a = d = alpha = 0, so a module bolted coaxially on the
      flange would make joint 7 coaxial with joint 6. Instead a rigid
      L-shaped adapter plate (fixed link 'adapter' on link6) carries module 1
      with its axis PERPENDICULAR to joint 6: in flange coordinates the
      module-1 input frame sits at (0.06, 0, -0.03) m, i.e. 0.06 m out
      along x_flange and 0.03 m back from the flange towards the wrist, with
      z_in = +x_flange (joint 7 axis, radial), x_in = +z_flange and
      y_in = -y_flange. Joint 7's axis meets joint 6's axis at right angles,
      0.03 m behind the flange. (Corke's model puts the flange at the wrist
      centre, d6 = 0; the adapter numbers are relative to that frame.)
  A2. Bracing frame {b} = fixed frame 'brace' on link6: the tip of a
      contact pad on the joint-6 axis, 0.05 m beyond the flange along
      +z_flange, with z_b = -z_flange (x_b = x_flange, y_b = -y_flange):
      z_b points from the pad into the robot. Intended use: the PUMA
      points its wrist down (z_flange towards the floor), the pad rests on a
      horizontal table, z_b is then the table's upward normal; chain 1 =
      joints 1..6, chain 2 = joints 7..11. Clearance: an X8 housing (about
      110 x 73 x 45 mm) reaches about 0.037 m from its axis on its +x side
      and about 0.073 m on its -x side (HEBI CoM at x = -0.0145). With
      x_in = +z_flange the short side faces the table, so module 1 ends
      about 0.007 m beyond the flange while the pad tip is 0.05 m beyond it
      (about 0.04 m clearance). The HEBI arm extends sideways or forwards
      above the table; whether the links clear the table in a given pose is
      up to the pose.
  A3. Adapter plate and pad: 0.15 kg placeholder mass, lumped with module
      1's housing into the 'adapter' inertial.
  A4. Example "wrist down, arm forward" pose (checked in tests/test_models.py):
      q = [0, 0.1924, -2.594, 0, -0.74, -3.1416,
           0.2, -3.0734, 1.9224, 0.2834, 0.3] rad
      puts the flange z axis straight down, 'brace' at (0.700, -0.150,
      -0.300) m with z_b up, x_flange (joint 7 axis) pointing forward along
      world +x, and 'tool' at (1.150, -0.279, -0.200) m: 0.47 m from the pad
      horizontally, 0.10 m above the table plane. theta5 = -0.74 rad.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from _models_urdf import (  # the sibling module: a script's own folder is first on sys.path
    PI,
    Inertial,
    Urdf,
    dh_constant,
    homogeneous,
    inertial,
    num,
    placement,
    rot_x,
    sphere,
)

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "src" / "bracekit" / "model" / "urdf"

# --- PUMA 560 (Corke's toolbox, standard DH) -------------------------------
PUMA_A = (0.0, 0.4318, 0.0203, 0.0, 0.0, 0.0)
PUMA_D = (0.0, 0.0, 0.15005, 0.4318, 0.0, 0.0)
PUMA_ALPHA = (PI / 2, 0.0, -PI / 2, PI / 2, -PI / 2, 0.0)
PUMA_LIMITS_DEG = (
    (-160.0, 160.0),
    (-45.0, 225.0),
    (-225.0, 45.0),
    (-110.0, 170.0),
    (-100.0, 100.0),
    (-266.0, 266.0),
)
PUMA_EFFORT = (100.0, 190.0, 90.0, 25.0, 20.0, 20.0)  # Nm, placeholders (P5)
PUMA_VELOCITY = (4.0, 4.0, 4.0, 5.0, 5.0, 5.0)  # rad/s, placeholders (P5)
# Armstrong et al. (1986) via Corke: mass, CoM and principal inertia, all in
# DH frame i. Link 1 and link 3 edited as documented in P6.
PUMA_MASS = (1.0, 17.4, 4.8, 0.82, 0.34, 0.09)
PUMA_COM = (
    (0.0, 0.0, 0.0),
    (-0.3638, 0.006, 0.2275),
    (-0.0203, -0.0141, 0.070),
    (0.0, 0.019, 0.0),
    (0.0, 0.0, 0.0),
    (0.0, 0.0, 0.032),
)
PUMA_INERTIA = (
    (0.18, 0.35, 0.18),
    (0.13, 0.524, 0.539),
    (0.066, 0.086, 0.0205),
    (1.8e-3, 1.3e-3, 1.8e-3),
    (0.3e-3, 0.4e-3, 0.3e-3),
    (0.15e-3, 0.15e-3, 0.04e-3),
)

# --- HEBI X8-16 arm ------------------------------------------------------------
X8_OUTPUT_Z = 0.0451  # m, output frame along input z (H2)
X8_MASS = 0.5
X8_COM = (-0.0145, -0.0031, 0.0242)  # hebi_description X8 housing
X8_INERTIA = (
    (0.000246, 0.0000444, 0.0000266),
    (0.0000444, 0.000380, 0.00000422),
    (0.0000266, 0.00000422, 0.000463),
)
X8_EFFORT = 38.0
X8_VELOCITY = 1.571
HEBI_LIMIT = 2.0 * PI
TUBE_EXTENSION = 0.325
TUBE_TWIST = PI
TUBE_EDGE = 0.0175
HEAVY_BRACKET_XYZ = (0.0, -0.0375, 0.055)
HEAVY_BRACKET_RX = PI / 2
HEAVY_BRACKET_MASS = 0.215
LIGHT_BRACKET_XYZ = (0.0, -0.043, 0.04)
LIGHT_BRACKET_RX = PI / 2
LIGHT_BRACKET_MASS = 0.1
TOOL_OFFSET = 0.10
TOOL_MASS = 0.05  # output hub + tool stub placeholder (H6)

# --- flange adapter and brace pad (A1-A3) --------------------------------------
ADAPTER_XYZ = (0.06, 0.0, -0.03)  # module-1 input origin, flange coordinates
ADAPTER_ROT = ((0.0, 0.0, 1.0), (0.0, -1.0, 0.0), (1.0, 0.0, 0.0))  # cols x,y,z
ADAPTER_MASS = 0.15
ADAPTER_PLATE_COM = (0.03, 0.0, -0.015)  # flange coordinates
BRACE_OFFSET = 0.05


def assumptions() -> str:
    """Return the 'Assumptions' section of this module's docstring."""
    doc = __doc__ or ""
    return doc.split("Assumptions\n===========\n", 1)[1]


def section(title: str) -> str:
    """One titled block of the assumptions."""
    blocks = assumptions().split("\n\n")
    return next(b for b in blocks if b.startswith(title))


def add_puma(urdf: Urdf) -> None:
    """PUMA 560 links/joints base_link..link6 and the 'flange' frame."""
    urdf.comment("base_link = DH frame 0 (no pedestal); no inertial, it is fixed")
    urdf.link("base_link")
    parent, parent_tf = "base_link", np.eye(4)
    for i in range(6):
        lower, upper = (math.radians(v) for v in PUMA_LIMITS_DEG[i])
        origin_note = "identity (DH frame 0)" if i == 0 else f"Tz(d{i}) Tx(a{i}) Rx(alpha{i}) of DH row {i}"
        urdf.comment(f"joint{i + 1}: about z of DH frame {i}; origin = {origin_note}")
        urdf.joint(
            f"joint{i + 1}",
            parent,
            f"link{i + 1}",
            parent_tf,
            (lower, upper, PUMA_EFFORT[i], PUMA_VELOCITY[i]),
        )
        dh = dh_constant(PUMA_D[i], PUMA_A[i], PUMA_ALPHA[i])
        body = inertial(PUMA_MASS[i], PUMA_COM[i], PUMA_INERTIA[i]).moved(dh)
        urdf.comment(f"link{i + 1}: DH row {i + 1}: a={num(PUMA_A[i])} d={num(PUMA_D[i])} alpha={num(PUMA_ALPHA[i])}")
        urdf.link(f"link{i + 1}", body)
        parent, parent_tf = f"link{i + 1}", dh
    urdf.comment("flange = DH frame 6; origin = Tz(d6) Tx(a6) Rx(alpha6) = identity")
    urdf.joint("flange_mount", "link6", "flange", parent_tf)
    urdf.link("flange")


def build_puma() -> str:
    """Text of puma560.urdf."""
    header = (
        "PUMA 560, standard DH (Corke's toolbox), no pedestal.\n"
        "Generated by tools/build_models.py; do not edit by hand.\n\n" + section("PUMA 560")
    )
    urdf = Urdf("puma560", header)
    add_puma(urdf)
    return urdf.text()


def x8_joint_origin() -> np.ndarray:
    """Input face to output frame of an X8 module."""
    return homogeneous(xyz=(0.0, 0.0, X8_OUTPUT_Z))


def tube_output(extension: float, twist: float) -> np.ndarray:
    """Output frame of a HEBI tube link in its input frame (H3)."""
    xyz = (extension, -TUBE_EDGE * math.sin(twist), TUBE_EDGE * (1 + math.cos(twist)))
    return homogeneous(rot_x(twist), xyz)


def tube_inertial(extension: float) -> Inertial:
    """Thin-rod tube link inertial in its input frame (hebi_description)."""
    mass = 0.4 * (extension + 0.03) + 0.26
    e = TUBE_EDGE
    axial = mass * e * e / 2.0
    transverse = mass * (extension**2 + 6 * e * e) / 12.0
    return inertial(mass, (extension / 2, 0.0, e), (axial, transverse, transverse))


def x8_housing() -> Inertial:
    """X8 housing inertial in its input frame."""
    return inertial(X8_MASS, X8_COM, X8_INERTIA)


def adapter_transform() -> np.ndarray:
    """Module-1 input frame in flange (link6) coordinates (A1)."""
    return homogeneous(np.array(ADAPTER_ROT), ADAPTER_XYZ)


def brace_transform() -> np.ndarray:
    """Bracing frame {b} in flange (link6) coordinates (A2)."""
    return homogeneous(rot_x(PI), (0.0, 0.0, BRACE_OFFSET))


def build_paper_robot() -> str:
    """Text of paper_robot.urdf."""
    header = (
        "Paper robot (Johnston, Orekhov, Simaan, ICRA 2020): PUMA 560 carrying\n"
        "five HEBI X8-16 modules, 11 revolute joints in one serial chain.\n"
        "Generated by tools/build_models.py; do not edit by hand.\n\n" + assumptions().rstrip()
    )
    urdf = Urdf("paper_robot", header)
    add_puma(urdf)

    urdf.comment(f"A2: bracing frame {{b}} (pad tip) on link6: {placement(brace_transform())}, so z_b = -z_flange")
    urdf.joint("brace_mount", "link6", "brace", brace_transform())
    urdf.link("brace")

    a_tf = adapter_transform()
    urdf.comment(
        f"A1: L-shaped flange adapter, 'adapter' = module-1 input frame: "
        f"{placement(a_tf)}; z_in = +x_flange, perpendicular to joint 6"
    )
    plate = sphere(ADAPTER_MASS, ADAPTER_PLATE_COM, radius=0.04)
    urdf.joint("adapter_mount", "link6", "adapter", a_tf)
    urdf.link("adapter", x8_housing() + plate.moved(np.linalg.inv(a_tf)))

    x8_limit = (-HEBI_LIMIT, HEBI_LIMIT, X8_EFFORT, X8_VELOCITY)
    heavy = homogeneous(rot_x(HEAVY_BRACKET_RX), HEAVY_BRACKET_XYZ)
    light = homogeneous(rot_x(LIGHT_BRACKET_RX), LIGHT_BRACKET_XYZ)
    tube = tube_output(TUBE_EXTENSION, TUBE_TWIST)
    heavy_body = sphere(HEAVY_BRACKET_MASS, (0.0, HEAVY_BRACKET_XYZ[1] / 2, 0.0275))
    light_body = sphere(LIGHT_BRACKET_MASS, (0.0, LIGHT_BRACKET_XYZ[1] / 2, 0.02))
    # (module input link, output link, fixed part after the output, its name,
    #  next input link, body carried by the output link)
    stages = [
        (
            "adapter",
            "link7",
            heavy,
            "heavy_bracket",
            "module2",
            heavy_body,
            f"H4: heavy bracket, right outside: {placement(heavy)}",
        ),
        (
            "module2",
            "link8",
            tube,
            "tube_link1",
            "module3",
            tube_inertial(TUBE_EXTENSION),
            f"H3: tube link: {placement(tube)}",
        ),
        (
            "module3",
            "link9",
            tube,
            "tube_link2",
            "module4",
            tube_inertial(TUBE_EXTENSION),
            f"H3: tube link: {placement(tube)}",
        ),
        (
            "module4",
            "link10",
            light,
            "light_bracket",
            "module5",
            light_body,
            f"H5: light bracket, right: {placement(light)}",
        ),
    ]
    for k, (inp, out, fixed, fixed_name, nxt, body, note) in enumerate(stages):
        urdf.comment(f"H2: X8-16 module {k + 1}, joint at its output: {placement(x8_joint_origin())}")
        urdf.joint(f"joint{k + 7}", inp, out, x8_joint_origin(), x8_limit)
        urdf.link(out, body)
        urdf.comment(note)
        urdf.joint(fixed_name, out, nxt, fixed)
        urdf.link(nxt, x8_housing())
    urdf.comment(f"H2: X8-16 module 5, joint at its output: {placement(x8_joint_origin())}")
    urdf.joint("joint11", "module5", "link11", x8_joint_origin(), x8_limit)
    urdf.link("link11", sphere(TOOL_MASS, (0.0, 0.0, TOOL_OFFSET / 2), radius=0.03))
    tool_tf = homogeneous(xyz=(0.0, 0.0, TOOL_OFFSET))
    urdf.comment(f"H6: end effector {{e}} on link11: {placement(tool_tf)}")
    urdf.joint("tool_mount", "link11", "tool", tool_tf)
    urdf.link("tool")
    return urdf.text()


def write_models(out_dir: Path) -> list[Path]:
    """Write both URDF files into ``out_dir``; return their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, text in (
        ("puma560.urdf", build_puma()),
        ("paper_robot.urdf", build_paper_robot()),
    ):
        path = out_dir / name
        path.write_text(text, encoding="utf-8")
        written.append(path)
    return written


def main(argv: list[str] | None = None) -> None:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description="Generate bracekit URDF models.")
    parser.add_argument(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        help="output directory (default: src/bracekit/model/urdf)",
    )
    parser.add_argument("--quiet", action="store_true", help="do not print the assumptions")
    args = parser.parse_args(argv)
    for path in write_models(args.out):
        print(f"wrote {path}")
    if not args.quiet:
        print("\nAssumptions\n===========\n" + assumptions())


if __name__ == "__main__":
    main()
