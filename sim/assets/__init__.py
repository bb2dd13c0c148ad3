"""What the simulator reads from a dataset: modules (loading.py, module.json and STL only)
and assemblies played stage by stage (assembly.py)."""
