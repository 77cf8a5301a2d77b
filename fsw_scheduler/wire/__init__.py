"""What travels on the bus: message Structs, key expressions, codecs.

Pure: no Zenoh here, only the formats the shell sends and receives.
"""
