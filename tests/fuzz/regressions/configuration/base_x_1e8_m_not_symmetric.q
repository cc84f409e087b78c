base_x 1e8
