<gml><tag><drawing>
  <stroke><pt><x>0.1</x><y>0.1</y></pt><pt><x>left</x><y>0.5</y></pt></stroke>
</drawing></tag></gml>
