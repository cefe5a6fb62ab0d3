<gml><tag><drawing>
  <stroke><pt><x>0.5</x><y>0.5</y></pt><pt><x>0.5</x><y>0.5</y></pt><pt><x>0.5</x><y>0.5</y></pt></stroke>
  <stroke><pt><x>0.5</x><y>0.5</y></pt><pt><x>0.5</x><y>0.5</y></pt></stroke>
</drawing></tag></gml>
