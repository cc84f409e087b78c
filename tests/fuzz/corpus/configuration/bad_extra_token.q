elbow 1 2
