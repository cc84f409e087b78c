ball_qw 1e155
ball_qx 1e155
