"""How a ROS 2 bag is cut into demonstrations: the names of the ``split`` choices
(:mod:`scenes.bags` says what each does). Its own module so a command-line parser can offer
them without loading the bag reader, SciPy or rosbags."""

#: the ``split`` choices: "auto" (rests judged against the recording's own motion), "bag"
#: (one demonstration per bag), "rest" (cut at every rest of a fixed speed and duration)
SPLITS = ("auto", "bag", "rest")
