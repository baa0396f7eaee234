# My own top controller, written by hand.  # expect: E304
X = 1
