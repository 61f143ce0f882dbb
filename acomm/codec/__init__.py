# The codec layer: bit packing, checksums, authentication tags, forward
# error correction, compression and the schema codec (fields, message,
# text6). Empty on purpose: a board that needs a CRC must not load the
# schema codec, so import the module you use (acomm.codec.fields, ...).
