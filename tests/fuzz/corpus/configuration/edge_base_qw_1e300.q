base_qw 1e300
