base_qw 0
