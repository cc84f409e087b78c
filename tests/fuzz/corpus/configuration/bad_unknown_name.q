knee 1
