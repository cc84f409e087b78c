# named entries; the rest stay neutral
base_x 0.5
base_qw 0.9
base_qx 0.1
ball_qz 1
elbow -0.3   
slider 0.05
