"""Dev studies of the camera-only servo: its position fixes, arrival and the lawn survey,
measured offline and on the dev split."""
