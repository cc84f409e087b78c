base_x 1e200
