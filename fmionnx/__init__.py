"""fmionnx: declarative pipelines of FMUs, ONNX models and MuJoCo, checked like a compiler."""

__version__ = "0.1.0"
