class Timer:
    enable = True
    enable_display_output = True
