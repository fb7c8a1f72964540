from ftin.cli import main

main()
