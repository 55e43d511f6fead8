"""The autoencoder: config, numpy inference, and the model file."""
