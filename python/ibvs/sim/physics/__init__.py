"""ibvs.sim.physics: the physics testbed, MuJoCo (pip install ".[physics]" from the ibvs repository root;
headless rendering needs OSMesa: apt-get install libosmesa6, used unless MUJOCO_GL says otherwise).

    world = World(ibvs.sim.cases.arm_robot("panda"), case.target, testbed_camera(320, 240))
    clock = PhysicsClock(world)                    # sleep_until(t) steps the physics to t
    robot = MujocoRobot(world)                     # an ibvs.robot.Robot: joint velocities to the actuators
    source = MujocoCamera(world, latency=0.05)     # an ibvs.vision.sources.FrameSource: rendered frames

Modules: world (World: the MuJoCo model, built from the arm's URDF in code; testbed_camera), adapters
(MujocoRobot, MujocoCamera, PhysicsClock), episode (run: a case closed through the servo on rendered
images). See docs/physics.md.
"""

from __future__ import annotations

from .adapters import MujocoCamera, MujocoRobot, PhysicsClock
from .episode import PhysicsResult, overshoot, run, run_loop
from .world import INSTALL, World, mujoco_module, testbed_camera

__all__ = ["INSTALL", "MujocoCamera", "MujocoRobot", "PhysicsClock", "PhysicsResult", "World", "mujoco_module",
           "overshoot", "run", "run_loop", "testbed_camera"]
