from hil_bench.cli import main

raise SystemExit(main())
