"""The style converter: whitening/colouring, elastic patch search, and the transfer pipeline."""
