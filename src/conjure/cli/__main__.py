"""``python -m conjure.cli``: the ``conjure`` command."""

from conjure.cli.main import main

if __name__ == "__main__":  # worker processes import this module again: they must not run it
    main()
