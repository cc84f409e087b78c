ball_qw 1e-11
ball_qx 1e-11
