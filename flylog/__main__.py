"""``python -m flylog``: the ``flylog`` command, for an environment whose scripts directory
is not on the ``PATH``."""

if __name__ == "__main__":
    from flylog.cli.main import main

    main()
