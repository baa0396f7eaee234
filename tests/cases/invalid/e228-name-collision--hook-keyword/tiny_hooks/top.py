def new_state(settings):
    return {}
