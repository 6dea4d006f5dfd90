from cablefem.app.cli import main

raise SystemExit(main())
