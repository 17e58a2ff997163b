"""supermat's Python tools: training data, training, evaluation and the demo's helpers (python/README.md).

Run a tool as a module with this folder's parent on the path, from the repository root:
    PYTHONPATH=python /usr/bin/python3 -m supermat_tools.gen_data --help
"""
