"""Writers that turn a system into other formats: SSP archives and YAML system files."""
