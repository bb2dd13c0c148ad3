"""The physics engines that step the task: MuJoCo on the CPU (mujoco/), PhysX through SAPIEN,
the referee (physx/), and MuJoCo Warp on a GPU (warp/)."""
