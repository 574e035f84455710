"""``python -m ctrlblocks.web [CONFIG] [options]``: the same as ``ctrlblocks serve``."""

from .cli import serve

if __name__ == "__main__":
    serve(prog_name="python -m ctrlblocks.web")
