"""OpenCL C sources of texray, shipped inside the wheel as the package ``texray.kernels``."""
