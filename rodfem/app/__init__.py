"""The application: scenes, the command line and the driver that owns output directories,
files and exit codes."""
