"""The beam's structures and the coupled simulation of a sloshing model in them.

``structure`` (cantilever + tank, the modal model), ``modes`` and ``modal_files`` (your own
structure's normal modes and their files), ``wing`` (a two-mode wing), ``coupled`` (the
coupled simulation), ``envelope`` (the tank motion a test asks of a model), ``members`` (an
ensemble ROM coupled member by member), ``cases`` (every case of a test, Table 1) and
``programme`` (the shaker programme of the structure's own motion).
"""
