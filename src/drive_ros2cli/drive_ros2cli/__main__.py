from drive_ros2cli.cli import main

raise SystemExit(main())
