"""PhysX through SAPIEN 3, the referee engine: its settings (config.py), the module read from
its USD file (usd_module.py) and the batched stepping (batch.py)."""
