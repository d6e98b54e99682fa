"""``python -m conjure.cli``: the ``conjure`` command."""

from conjure.cli.main import main

main()
