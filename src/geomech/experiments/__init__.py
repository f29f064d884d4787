"""Named, reproducible studies: config -> run -> data + figures + summary."""
