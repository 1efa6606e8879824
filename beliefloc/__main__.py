from beliefloc.cli.app import main

main()
