elbow 1
elbow 2
