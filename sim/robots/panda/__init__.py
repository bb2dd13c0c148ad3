"""The Franka Emika Panda: its model (read from gymnasium-robotics), the scene with a module,
the kinematics and the batched simulation."""
