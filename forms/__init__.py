"""The physics of rodfem in UFL: one module per model, materials as energy functions.

Edit here to add a material: write W(strains) -> UFL scalar and pass it to the model.
"""
