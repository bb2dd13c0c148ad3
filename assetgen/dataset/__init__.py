"""Stage 6, datasets on disk: specs (`spec`), reading a dataset without the CAD stack
(`reader`), resumable parallel generation (`generate`) through the per-module writer that
builds, checks and writes a module in a temporary folder and renames it when complete
(`module_writer`), re-checking or repairing a dataset (`check`), and the commands that drive
them (`sample_command`, `check_command`, `info_command`: `assetgen sample`, `check`, `info`)."""
