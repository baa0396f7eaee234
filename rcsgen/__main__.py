from rcsgen.cli import main

main()
