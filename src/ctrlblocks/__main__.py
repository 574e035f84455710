"""``python -m ctrlblocks``: the command line, as the ``ctrlblocks`` script."""

from ctrlblocks.cli import main

if __name__ == "__main__":
    main()
