"""A laboratory's beam tests as files: written, read, checked and analysed at every mode.

``channels`` (which channel is which accelerometer), ``measured`` (the readers of a lab's
tests and the checks of their data), ``uff58`` (the beam's UFF 58 files: node numbering,
writer, the readers' channel lookup), ``virtual`` (the virtual rig's runs written as a lab's
files), ``synthetic`` (a laboratory's beam of known modes and its tests), ``campaign`` (a
campaign folder) and ``every_mode`` (a measured test at every mode of its band).
"""
