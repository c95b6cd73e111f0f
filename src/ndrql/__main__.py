"""Allow ``python -m ndrql`` (and ``torchrun -m ndrql``)."""

from ndrql.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
