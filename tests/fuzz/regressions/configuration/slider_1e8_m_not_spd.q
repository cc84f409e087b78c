slider 1e8
